"""The control layer: PID, inverse task Jacobian (Eq. 5), projections, the servo command; SE(3).

Layer 3 of the control cycle; imports only the layers below it.
"""
