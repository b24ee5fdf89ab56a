"""py_trees leaves for every tactile servoing primitive, and the registry the YAML loader uses.

Every class declares its parameters once (:class:`~tactile_bt.tree.declaration.Parameter`: type,
default, unit, range, meaning) and is built with them as keyword arguments; the YAML node types
below map to these classes, so a tree built in Python and one loaded from YAML are the same
objects.

Layer: tree.
"""

from tactile_bt.tree.behaviours.base import ServoLeaf, TactileBehaviour, TactileDecorator
from tactile_bt.tree.behaviours.cable import CableEnd
from tactile_bt.tree.behaviours.cable_recovery import Backtrack
from tactile_bt.tree.behaviours.decorators import Inverter, OneShot, Repeat, Retry
from tactile_bt.tree.behaviours.guards import ContactLost, ForceLimit, MissionTimeout
from tactile_bt.tree.behaviours.motion import Approach, GuidedSlide
from tactile_bt.tree.parameters import bind_blackboard
from tactile_bt.errors import BlackboardReferenceError
from tactile_bt.tree.behaviours.contact_points import RecordContacts
from tactile_bt.tree.behaviours.scan import CoverageStalled, ScanDirection
from tactile_bt.tree.behaviours.surface_end import (ContactBridged, ContactJumped, ContactShrank, ContactStalled,
                                                    PadTurned, RollingOverEdge, TiltLimit, Travelled)
from tactile_bt.tree.behaviours.table import TableClearance
from tactile_bt.tree.behaviours.frontier import FrontierGuidance
from tactile_bt.tree.behaviours.border_sweep import BorderSweep
from tactile_bt.tree.behaviours.hole_probe import HoleProbe
from tactile_bt.tree.behaviours.reapproach import Reapproach, ReturnToSurface
from tactile_bt.tree.behaviours.placement import CentreTo, RollTo, SquareToSlope, TableOffset
from tactile_bt.tree.behaviours.servo import AlignEdge, Centre, ForceHold, Roll, TactileServo
from tactile_bt.tree.behaviours.supervision import SupervisorRetreat
from tactile_bt.tree.behaviours.stiffness import AdaptForceTarget

#: YAML node type → leaf class.
LEAVES = {
    "approach": Approach,
    "force_hold": ForceHold,
    "centre": Centre,
    "roll": Roll,
    "align_edge": AlignEdge,
    "tactile_servo": TactileServo,
    "guided_slide": GuidedSlide,
    "record_contacts": RecordContacts,
    "scan_direction": ScanDirection,
    "tilt_limit": TiltLimit,
    "pad_turned": PadTurned,
    "contact_jumped": ContactJumped,
    "rolling_over_edge": RollingOverEdge,
    "contact_shrank": ContactShrank,
    "travelled": Travelled,
    "contact_stalled": ContactStalled,
    "contact_bridged": ContactBridged,
    "coverage_stalled": CoverageStalled,
    "cable_end": CableEnd,
    "backtrack": Backtrack,
    "frontier_guidance": FrontierGuidance,
    "reapproach": Reapproach,
    "return_to_surface": ReturnToSurface,
    "border_sweep": BorderSweep,
    "hole_probe": HoleProbe,
    "table_clearance": TableClearance,
    "table_offset": TableOffset,
    "centre_to": CentreTo,
    "roll_to": RollTo,
    "square_to_slope": SquareToSlope,
    "contact_lost": ContactLost,
    "force_limit": ForceLimit,
    "supervisor_retreat": SupervisorRetreat,
    "adapt_force_target": AdaptForceTarget,
}
#: YAML node type → decorator class (first argument: the child).
DECORATORS = {
    "mission_timeout": MissionTimeout,
    "retry": Retry,
    "repeat": Repeat,
    "inverter": Inverter,
    "oneshot": OneShot,
}

for _type_name, _cls in (*LEAVES.items(), *DECORATORS.items()):
    _cls.node_type = _type_name  # the YAML type, for messages (tactile_bt.tree.parameters.node_label)

__all__ = [
    "TactileBehaviour",
    "ServoLeaf",
    "Approach",
    "ForceHold",
    "Centre",
    "Roll",
    "AlignEdge",
    "TactileServo",
    "GuidedSlide",
    "RecordContacts",
    "ScanDirection",
    "TiltLimit",
    "PadTurned",
    "ContactJumped",
    "RollingOverEdge",
    "ContactShrank",
    "Travelled",
    "ContactStalled",
    "ContactBridged",
    "CoverageStalled",
    "CableEnd",
    "Backtrack",
    "FrontierGuidance",
    "Reapproach",
    "ReturnToSurface",
    "BorderSweep",
    "HoleProbe",
    "TableClearance",
    "TableOffset",
    "CentreTo",
    "RollTo",
    "SquareToSlope",
    "ContactLost",
    "SupervisorRetreat",
    "AdaptForceTarget",
    "ForceLimit",
    "MissionTimeout",
    "Retry",
    "Repeat",
    "Inverter",
    "OneShot",
    "BlackboardReferenceError",
    "bind_blackboard",
    "TactileDecorator",
    "LEAVES",
    "DECORATORS",
]
