"""The contacts layer: contact cloud, its files and its reconstruction into a surface.

Layer 6 of the control cycle (T_gs * contact point -> cloud); imports only the layers below it.
"""
