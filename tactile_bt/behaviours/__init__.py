"""py_trees leaves for every tactile servoing primitive, and the registry the YAML loader uses."""

from tactile_bt.behaviours.base import NAMESPACE, ServoLeaf, TactileBehaviour
from tactile_bt.behaviours.guards import ContactLost, ForceLimit, MissionTimeout
from tactile_bt.behaviours.motion import Approach, GuidedSlide
from tactile_bt.behaviours.record import ContactCloud, RecordContacts
from tactile_bt.behaviours.servo import AlignEdge, Centre, ForceHold, Roll, TactileServo

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
    "contact_lost": ContactLost,
    "force_limit": ForceLimit,
}
#: YAML node type → decorator class (first argument: the child).
DECORATORS = {"mission_timeout": MissionTimeout}

__all__ = [
    "NAMESPACE",
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
    "ContactCloud",
    "ContactLost",
    "ForceLimit",
    "MissionTimeout",
    "LEAVES",
    "DECORATORS",
]
