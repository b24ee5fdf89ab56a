"""The behaviour layer: blackboard adapter, leaves, guards, decorators and the YAML loader.

Layer 4 of the control cycle; imports only the layers below it.
"""
