"""The sensing layer: the pad's geometry, the calibration of its tactels, the serial driver.

Layer 1 of the control cycle (raw frame -> force image); imports nothing above it.
"""
