"""The tactile modules the serial driver knows: name, array shape and the device's cell order.

A module's *cell order* says which word of a data datagram carries which tactel. The project's
convention (:func:`tactile_bt.sense.hardware.protocol.cell_permutation`): ``cell_order[k]`` is
the row-major index ``row * cols + col`` of the tactel sent as the k-th word.

``tactile_module_16x16_v2``
    The Bielefeld 16x16 module (the "Myrmex" of the paper's experiments). Its table is
    ``myrmex_data_lut`` of the reference driver, ubi-agni/agni_serial_protocol,
    ``libio/registered_sensors_impl.h`` (``Sensor_myrmex_v2::parse``), which fills the
    row-major image as ``tactile_array[i] = word[lut[i]]``: the word index for each tactel. The
    module's cell order is therefore the inverse permutation, ``argsort(lut)``.
``row_major``
    Word k is tactel k in row-major order (row 0 first), any array shape: the default for every
    other module, and the emulator's.

A module is named in the driver's ``module=``, by ``--module`` on ``tactile-bt sensor ...``, or,
when neither names one, by the configuration answer: its sensor *type* number is looked up in
the reference driver's registration file (``registred_devices.yaml``: ``uid`` -> ``name``),
:func:`load_registration`.

Layer: sense (the serial sensor).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

import yaml

from tactile_bt.errors import SensorModuleError, YamlError
from tactile_bt.yamlutil import Loader, decode_utf8

__all__ = ["TactileModule", "MODULES", "DEFAULT_MODULE", "MYRMEX_V2_LUT", "get_module", "module_for_type",
           "load_registration"]

#: ``myrmex_data_lut`` of the reference driver (ubi-agni/agni_serial_protocol,
#: ``libio/registered_sensors_impl.h``): for each tactel of the row-major 16x16 image, the index
#: of the datagram word that carries it (``tactile_array[i] = word[lut[i]]``).
MYRMEX_V2_LUT: tuple[int, ...] = (
    208, 224,  32,   0, 209, 225,  33,   1, 210, 226,  34,   2, 211, 227,  35,   3,
    192,  48,  16,  64, 193,  49,  17,  65, 194,  50,  18,  66, 195,  51,  19,  67,
    176, 144, 112,  80, 177, 145, 113,  81, 178, 146, 114,  82, 179, 147, 115,  83,
    160, 240, 128,  96, 161, 241, 129,  97, 162, 242, 130,  98, 163, 243, 131,  99,
    212, 228,  36,   4, 213, 229,  37,   5, 214, 230,  38,   6, 215, 231,  39,   7,
    196,  52,  20,  68, 197,  53,  21,  69, 198,  54,  22,  70, 199,  55,  23,  71,
    180, 148, 116,  84, 181, 149, 117,  85, 182, 150, 118,  86, 183, 151, 119,  87,
    164, 244, 132, 100, 165, 245, 133, 101, 166, 246, 134, 102, 167, 247, 135, 103,
    216, 232,  40,   8, 217, 233,  41,   9, 218, 234,  42,  10, 219, 235,  43,  11,
    200,  56,  24,  72, 201,  57,  25,  73, 202,  58,  26,  74, 203,  59,  27,  75,
    184, 152, 120,  88, 185, 153, 121,  89, 186, 154, 122,  90, 187, 155, 123,  91,
    168, 248, 136, 104, 169, 249, 137, 105, 170, 250, 138, 106, 171, 251, 139, 107,
    220, 236,  44,  12, 221, 237,  45,  13, 222, 238,  46,  14, 223, 239,  47,  15,
    204,  60,  28,  76, 205,  61,  29,  77, 206,  62,  30,  78, 207,  63,  31,  79,
    188, 156, 124,  92, 189, 157, 125,  93, 190, 158, 126,  94, 191, 159, 127,  95,
    172, 252, 140, 108, 173, 253, 141, 109, 174, 254, 142, 110, 175, 255, 143, 111,
)


@dataclass(frozen=True)
class TactileModule:
    """A tactile module: its name, array shape and cell order.

    Attributes
    ----------
    name : str
        The module's name, as the reference driver registers it.
    rows, cols : int or None
        Array shape (tactels); None: any shape (``row_major``).
    word_of_tactel : tuple of int or None
        For each tactel in row-major order, the index of the datagram word that carries it (the
        reference driver's form of the table); None for row-major.
    source : str
        Where the table comes from.
    """

    name: str
    rows: int | None = None
    cols: int | None = None
    word_of_tactel: tuple[int, ...] | None = None
    source: str = ""

    def check_shape(self, rows: int, cols: int) -> None:
        """SensorModuleError unless the module's array is ``rows`` x ``cols`` tactels."""
        if self.rows is not None and (rows, cols) != (self.rows, self.cols):
            raise SensorModuleError(f"module {self.name} has {self.rows}x{self.cols} tactels, "
                                    f"not {rows}x{cols} (rows x cols)")

    def cell_order(self, rows: int, cols: int) -> np.ndarray | None:
        """The cell order for ``rows`` x ``cols`` tactels (``cell_order[k]``: the row-major index of
        the k-th word; None for row-major); SensorModuleError if the shape is not the module's."""
        self.check_shape(rows, cols)
        if self.word_of_tactel is None:
            return None
        return np.argsort(np.asarray(self.word_of_tactel, dtype=np.intp))


DEFAULT_MODULE = "row_major"

#: The modules by name.
MODULES: dict[str, TactileModule] = {
    m.name: m
    for m in (
        TactileModule(DEFAULT_MODULE, source="word k is tactel k, row 0 first"),
        TactileModule("tactile_module_16x16_v2", 16, 16, MYRMEX_V2_LUT,
                      "ubi-agni/agni_serial_protocol, libio/registered_sensors_impl.h, myrmex_data_lut"),
    )
}


def get_module(name: str, where: str = "module") -> TactileModule:
    """The module called ``name``; SensorModuleError naming ``where`` and the known names otherwise."""
    module = MODULES.get(name)
    if module is None:
        raise SensorModuleError(f"{where}: unknown tactile module {name!r}; known: {', '.join(sorted(MODULES))}")
    return module


def module_for_type(sensor_type: int, registration: Mapping[int, str] | None) -> TactileModule | None:
    """The known module a configuration answer's sensor type names through ``registration``
    (type number -> module name), or None when it names none the driver knows."""
    name = (registration or {}).get(int(sensor_type))
    return MODULES.get(name) if name is not None else None


def load_registration(path: str | Path) -> dict[int, str]:
    """Sensor type numbers -> module names, from the reference driver's registration file.

    The file (``registred_devices.yaml`` of agni_serial_protocol) reads::

        agni_serial_protocol:
          1:                          # protocol version
            registered_devices:
              - {uid: "XXXX", name: tactile_module_16x16_v2, ...}   # uid: type number, hex

    Raises
    ------
    YamlError
        Naming the file, line and field of what is missing or malformed.
    """
    file = str(path)
    try:
        text = decode_utf8(Path(path).read_bytes(), file)
        root = yaml.compose(text, Loader=Loader)
    except OSError as exc:
        raise YamlError(f"cannot read: {exc.strerror}", file) from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        raise YamlError(f"invalid YAML: {exc.problem}", file, mark.line + 1 if mark else None) from None
    if root is None:
        raise YamlError("the file is empty", file)
    versions = _mapping(root, file, "the file").get("agni_serial_protocol")
    if versions is None:
        raise _error(root, file, "no 'agni_serial_protocol' section")
    out: dict[int, str] = {}
    for version, section in _mapping(versions, file, "agni_serial_protocol").items():
        field = f"agni_serial_protocol.{version}.registered_devices"
        entries = _mapping(section, file, f"agni_serial_protocol.{version}").get("registered_devices")
        if entries is None:
            continue
        if not isinstance(entries, yaml.SequenceNode):
            raise _error(entries, file, f"{field}: expected a list of devices")
        for k, entry in enumerate(entries.value):
            item = _mapping(entry, file, f"{field}[{k}]")
            for key in ("uid", "name"):
                if not isinstance(item.get(key), yaml.ScalarNode):
                    raise _error(item.get(key, entry), file, f"{field}[{k}].{key}: missing, or not a single value")
            try:
                number = int(item["uid"].value, 16)
            except ValueError:
                raise _error(item["uid"], file, f"{field}[{k}].uid: {item['uid'].value!r} is not a hex number") from None
            out[number] = item["name"].value
    return out


def _mapping(node: yaml.Node, file: str, field: str) -> dict[str, yaml.Node]:
    """A YAML mapping node's items, keys as text; YamlError naming ``field`` if it is no mapping."""
    if not isinstance(node, yaml.MappingNode):
        raise _error(node, file, f"{field}: expected a mapping")
    return {str(k.value): v for k, v in node.value}


def _error(node: yaml.Node, file: str, message: str) -> YamlError:
    return YamlError(message, file, node.start_mark.line + 1, node.start_mark.column + 1)
