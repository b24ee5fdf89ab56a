"""The perception layer: force image -> ContactFeatures (paper Eq. 1-2), smoothing.

Layer 2 of the control cycle; imports only tactile_bt.sense below it.
"""
