"""Every exception and warning of tactile_bt, in one place.

:class:`TactileBtError` is the base of the errors a user's input or set-up can cause: a YAML file,
a parameter, an option, a scene, a recording, a port. The command line prints any of them as one
line ``error: ...`` (their messages name the file with line and column, the field or the option)
and exits with code 2; anything else is a bug and keeps its traceback.

Layer: base (imports nothing of the package).
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "TactileBtError",
    "InputError",
    "YamlError",
    "TreeError",
    "SceneError",
    "ParameterTypeError",
    "ParameterValueError",
    "BlackboardReferenceError",
    "CommandLineError",
    "OutputPathError",
    "MissionLengthError",
    "MountError",
    "MeshError",
    "ProtocolError",
    "SensorModuleError",
    "RecordingError",
    "ReplayError",
    "SensorError",
    "SensorConnectionError",
    "SensorDisconnectedError",
    "UnknownNodeError",
    "MissionInterrupted",
    "RecordingWarning",
    "PluginError",
    "RobotConnectionError",
]


class TactileBtError(Exception):
    """Base of the errors that bad input or a bad set-up causes; printed as one line by the CLI."""


class InputError(TactileBtError, ValueError):
    """A value that cannot be used; the message names where it comes from."""


# --------------------------------------------------------------------------- files and values
class YamlError(InputError):
    """A problem in a YAML file, with ``file:line:column`` in its message."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None, column: int | None = None):
        self.file, self.line, self.column = file, line, column
        location = ""
        if file is not None:
            location = f"{file}"
            if line is not None:
                location += f":{line}"
                if column is not None:
                    location += f":{column}"
            location += ": "
        super().__init__(location + message)


#: The error of the tree loader (a located :class:`YamlError`, with ``message`` and ``field``).
TreeError = YamlError
#: The error of the scene loader (a located :class:`YamlError`).
SceneError = YamlError


class ParameterTypeError(TactileBtError, TypeError):
    """A value does not fit a parameter's type; ``expected`` says what would."""

    def __init__(self, expected: str, value: Any, detail: str = "") -> None:
        self.expected, self.value, self.detail = expected, value, detail
        super().__init__(detail or f"expected {expected}, got {value!r}")


class ParameterValueError(InputError):
    """A number outside its parameter's range (or not finite). ``detail`` says what is
    wrong without the parameter's name (``"must be > 0 (got -2000.0 Pa)"``); ``parameter``
    names it, ``index`` is the element of a list (None for a single number)."""

    def __init__(self, parameter: str | None, detail: str, index: int | None = None, node: str | None = None) -> None:
        self.parameter, self.detail, self.index, self.node = parameter, detail, index, node
        label = parameter or "value"
        if index is not None:
            label += f"[{index}]"
        super().__init__(f"{node + ': ' if node else ''}{label} {detail}")

    @property
    def message(self) -> str:
        """The message without the node (``target_pa must be > 0 (got -2000.0 Pa)``)."""
        return str(ParameterValueError(self.parameter, self.detail, self.index))


class BlackboardReferenceError(TactileBtError, RuntimeError):
    """A blackboard reference could not be resolved when its node started (missing key or a
    value of the wrong type). The message names the tree file, line and column of the
    reference, the node and parameter, and the key."""


class CommandLineError(InputError):
    """A command-line value that cannot be used; the message names the option or file."""


class OutputPathError(InputError):
    """An output file or directory that cannot (or may not) be written; the message names it."""


class MissionLengthError(InputError):
    """A mission budget that gives no cycle, or more than the log can hold."""


class MountError(InputError):
    """The mount cannot be built as specified (the arm cannot reach the start pose).

    ``field`` names the ``mount.`` field most likely to blame (``base`` or ``rpy_deg``).
    """

    def __init__(self, message: str, field: str = "") -> None:
        super().__init__(message)
        self.field = field


class MeshError(InputError):
    """A mesh file that cannot be used (unreadable, empty, not closed)."""


# --------------------------------------------------------------------------- sensor and recordings
class ProtocolError(InputError):
    """Malformed input to the AGNI protocol's builders or decoders."""


class SensorModuleError(InputError):
    """An unknown tactile module, or one whose array is not the shape asked for."""


class RecordingError(InputError):
    """A recording file is not readable; the message names the file and the byte offset."""


class ReplayError(InputError):
    """A replay cannot start: its calibration or pace is unusable; the message names which."""


class RobotConnectionError(TactileBtError, RuntimeError):
    """A robot that cannot be reached or stopped answering (no pose, ROS 2 missing)."""


class SensorError(TactileBtError, RuntimeError):
    """Base class of the serial driver's errors; the message names the port."""


class SensorConnectionError(SensorError):
    """The port could not be opened or the device did not configure."""


class SensorDisconnectedError(SensorError):
    """The port vanished while streaming (cable unplugged, emulator closed)."""


class PluginError(InputError):
    """A plugin (an entry point of ``tactile_bt.behaviours`` or a ``--plugin`` module) that cannot be
    loaded, or whose node type clashes with another; the message names both sides."""


# --------------------------------------------------------------------------- testing kit
class UnknownNodeError(KeyError):
    """A node name that is not in the tree under test (the message lists the known names)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


# --------------------------------------------------------------------------- interruptions
class MissionInterrupted(KeyboardInterrupt):
    """Ctrl-C during a mission that writes into an output directory, with what that directory
    holds now: ``written``, the files this run wrote there (its outputs of every cycle so far),
    or ``earlier``, the files of an earlier run it had not yet replaced. A
    :class:`KeyboardInterrupt`, so code that stops on Ctrl-C still does."""

    def __init__(self, out: Any, written: tuple[str, ...] = (), earlier: tuple[str, ...] = (),
                 sim_time_s: float | None = None) -> None:
        self.out, self.written, self.earlier, self.sim_time_s = out, tuple(written), tuple(earlier), sim_time_s
        super().__init__(self.describe())

    def describe(self) -> str:
        """``"at 3.20 s of mission time; out/cable holds this run's report.json, log.npz (every
        cycle so far)"``, or what else is true of the directory."""
        when = (f"at {self.sim_time_s:.2f} s of mission time" if self.sim_time_s is not None
                else "before the mission started")
        if self.written:
            return f"{when}; {self.out} holds this run's {', '.join(self.written)} (every cycle so far)"
        if self.earlier:
            return (f"{when}; nothing was written: {self.out} still holds an earlier run's "
                    f"{', '.join(self.earlier)}")
        return f"{when}; nothing was written to {self.out}"


# --------------------------------------------------------------------------- warnings
class RecordingWarning(UserWarning):
    """A recording replays, but not as it was made: a torn tail, a missing calibration file."""
