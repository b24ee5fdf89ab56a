"""The simulator: the world a mission runs in without hardware — scenes (YAML schema, objects,
events), the pad model that turns the pad's pose into raw frames, and the world that ties them to
a mount.

Layer 7: sim; imports the layers below it (sense, control, robot, ...), never mission or experiments.
"""
