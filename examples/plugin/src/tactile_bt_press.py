"""``press_until``: press along the pad normal until the contact pressure reaches a target.

A complete leaf of one's own, packaged as a tactile_bt plugin (see docs/writing_leaves.md):
installed (``pip install examples/plugin``), its entry point in ``tactile_bt.behaviours`` adds the
node type; not installed, ``--plugin examples/plugin/src/tactile_bt_press.py`` imports this file,
whose last line registers it.
"""

from __future__ import annotations

from py_trees.common import Status

from tactile_bt.tree import NON_NEGATIVE, POSITIVE, Parameter, TactileBehaviour, register_node

__all__ = ["PressUntil"]


class PressUntil(TactileBehaviour):
    """Move along the pad normal (+z of the sensor frame, towards the object) until the smoothed
    contact pressure reaches ``target_pa``; SUCCESS then. FAILURE when contact is lost after it
    was made, or after ``timeout_s`` of mission time.
    """

    uses = frozenset({"pressure"})  # the features this leaf reads: the mission computes only these
    # One declaration per parameter: default, bound and meaning; the unit follows from the name.
    target_pa = Parameter(3000.0, bound=POSITIVE, doc="Pressure to reach (Pa, > 0).")
    speed_mps = Parameter(0.002, bound=POSITIVE, doc="Pressing speed along +z_s (m/s, > 0).")
    timeout_s = Parameter(5.0, bound=NON_NEGATIVE, doc="Mission time allowed from the start of the leaf (s, >= 0).")
    _started = 0.0
    _touched = False

    def initialise(self) -> None:
        self._started = self.now  # the mission clock, never wall time
        self._touched = False

    def update(self) -> Status:
        f = self.features
        if f.in_contact:
            self._touched = True
        elif self._touched:
            self.feedback_message = "contact lost while pressing"
            return Status.FAILURE
        if f.in_contact and f.pressure >= self.target_pa:
            self.feedback_message = f"pressed to {f.pressure:.0f} Pa"
            return Status.SUCCESS
        if self.now - self._started > self.timeout_s:
            self.feedback_message = f"{self.target_pa:.0f} Pa not reached within {self.timeout_s:g} s"
            return Status.FAILURE
        self.command.add(self.name, (0.0, 0.0, self.speed_mps, 0.0, 0.0, 0.0))
        self.feedback_message = f"pressing, {f.pressure:.0f} of {self.target_pa:.0f} Pa"
        return Status.RUNNING


register_node("press_until", PressUntil)  # for --plugin; the entry point registers the same class
