"""The mission layer: the control loop, run and replay, results, metrics, outputs and the view.

Layer 8: it ties the cycle together over the simulator (layer 7) or a recording.
"""
