"""The robot layer: mounts and the KUKA LWR 4 (kinematics, resolved rates, compliance).

Layer 5 of the control cycle (twist -> joint motion); imports only the layers below it.
"""
