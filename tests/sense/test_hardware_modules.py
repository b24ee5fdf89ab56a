"""The real module's cell order: a tactile_module_16x16_v2 pressed in one corner gives the press in
that corner of the image, through the emulator, the serial line and the driver, and on the
command line; the module is named in Python, by --module, or by the device's configuration."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tactile_bt.cli import main
from tactile_bt.errors import SensorModuleError, YamlError
from tactile_bt.sense.hardware import DeviceEmulator, Recorder, SerialTactileSensor
from tactile_bt.sense.hardware import protocol as P
from tactile_bt.sense.hardware.modules import MODULES, MYRMEX_V2_LUT, get_module, load_registration

V2 = "tactile_module_16x16_v2"
T = 2.0  # s, timeouts of the serial line (never reached when things work)
CORNERS = {"top left": (0, 0), "top right": (0, 15), "bottom left": (15, 0), "bottom right": (15, 15)}
NO_PORT = "/nonexistent/tactile-port"


def corner_press(corner: str) -> np.ndarray:
    """Raw counts of a finger pressing 3x3 tactels in one corner of a 16x16 pad (row = y, col = x)."""
    row, col = CORNERS[corner]
    img = np.full((16, 16), 60, dtype=np.uint16)
    rows = slice(0, 3) if row == 0 else slice(13, 16)
    cols = slice(0, 3) if col == 0 else slice(13, 16)
    img[rows, cols] = 2500
    img[row, col] = 3200  # the peak in the corner tactel
    return img


def registration_file(path: Path, uid: str, name: str = V2) -> Path:
    """A registred_devices.yaml in the reference driver's format naming type ``uid`` (hex)."""
    path.write_text(f"""agni_serial_protocol:
  1:
    registered_devices:
      - uid: "{uid}"
        name: {name}
        manufacturer: Bielefeld University
        description: 16x16 tactile module
        parser_library: tactile::myrmex_v2
        data_length: 512
""")
    return path


def test_the_v2_table_is_a_permutation_in_the_reference_drivers_sense():
    lut = np.array(MYRMEX_V2_LUT)
    assert lut.shape == (256,) and np.array_equal(np.sort(lut), np.arange(256))
    # tactile_array[i] = word[lut[i]]: a payload whose word k holds k decodes to the table itself
    order = get_module(V2).cell_order(16, 16)
    payload = np.arange(256, dtype="<u2").tobytes()
    image = P.decode_values(payload, np.argsort(order))
    assert np.array_equal(image.ravel(), lut)
    assert image[0, 3] == 0 and image[0, 0] == 208 and image[15, 15] == 111  # rows 0 and 15 of the table
    assert get_module("row_major").cell_order(16, 16) is None  # every other module: row-major


@pytest.mark.parametrize("corner", CORNERS)
def test_an_emulated_v2_module_pressed_in_a_corner_gives_the_press_in_that_corner(corner):
    press = corner_press(corner)
    with DeviceEmulator(module=V2) as emu:
        with SerialTactileSensor(emu.port, module=V2, timeout=T) as sensor:
            emu.push(press)
            image = sensor.read(T).values
        assert np.unravel_index(np.argmax(image), image.shape) == CORNERS[corner]
        assert np.array_equal(image, press)
        with SerialTactileSensor(emu.port, timeout=T) as sensor:  # read as row-major: scrambled
            emu.push(press)
            assert not np.array_equal(sensor.read(T).values, press)


def test_the_configuration_answer_names_the_module_through_the_registration(tmp_path):
    press = corner_press("top right")
    registration = load_registration(registration_file(tmp_path / "registred_devices.yaml", "A716"))
    assert registration == {0xA716: V2}
    with DeviceEmulator(module=V2, sensor_type=0xA716) as emu:
        with SerialTactileSensor(emu.port, registration=registration, timeout=T) as sensor:
            emu.push(press)
            assert sensor.module == V2
            assert np.array_equal(sensor.read(T).values, press)
        with SerialTactileSensor(emu.port, registration={0x0001: V2}, timeout=T) as sensor:
            assert sensor.module == "row_major"  # a type the registration does not name


def test_a_wrong_module_name_or_shape_is_a_clear_error_before_the_port_opens():
    with pytest.raises(SensorModuleError, match=r"unknown tactile module 'myrmex'; known: row_major, "
                                                rf"{V2}"):
        SerialTactileSensor(NO_PORT, module="myrmex")
    with pytest.raises(SensorModuleError, match=rf"module {V2} has 16x16 tactels, not 8x8"):
        SerialTactileSensor(NO_PORT, module=V2, rows=8, cols=8)
    with pytest.raises(SensorModuleError, match="or a cell order, not both"):
        SerialTactileSensor(NO_PORT, module=V2, cell_order=np.arange(256))
    with pytest.raises(SensorModuleError, match="unknown tactile module 'v3'"):
        DeviceEmulator(module="v3")
    assert set(MODULES) == {"row_major", V2}


@pytest.mark.parametrize("text, where", [
    ("agni_serial_protocol:\n  1:\n    registered_devices:\n      - uid: \"zz\"\n        name: x\n",
     ":4:14: agni_serial_protocol.1.registered_devices[0].uid: 'zz' is not a hex number"),
    ("agni_serial_protocol:\n  1:\n    registered_devices:\n      - name: x\n",
     ":4:9: agni_serial_protocol.1.registered_devices[0].uid: missing"),
    ("devices: []\n", ":1:1: no 'agni_serial_protocol' section"),
    ("agni_serial_protocol:\n  1:\n    registered_devices: {a: 1}\n",
     ":3:25: agni_serial_protocol.1.registered_devices: expected a list"),
])
def test_a_bad_registration_file_is_an_error_naming_file_line_and_field(tmp_path, text, where):
    path = tmp_path / "reg.yaml"
    path.write_text(text)
    with pytest.raises(YamlError) as info:
        load_registration(path)
    assert str(info.value).startswith(f"{path}{where}")


def cli(argv, capsys) -> tuple[int, str, str]:
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse
        rc = exc.code
    out, err = capsys.readouterr()
    return rc, out, err


def test_sensor_stream_on_an_emulated_v2_module_shows_the_press_in_its_corner(tmp_path, capsys):
    recording = tmp_path / "corner.tbr"
    with Recorder(recording, 16, 16) as rec:
        rec.write(corner_press("bottom left"), timestamp=0.0)
    emulate = [sys.executable, "-m", "tactile_bt.sense.hardware.cli", "sensor", "emulate", "--module", V2,
               "--recording", str(recording), "--rate", "250", "--duration", "30"]
    proc = subprocess.Popen(emulate, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = proc.stdout.readline().strip()
        assert port.startswith("/dev/"), proc.stderr.read()
        rc, out, err = cli(["sensor", "stream", port, "--module", V2, "--duration", "0.5", "--every", "0.1"], capsys)
        assert rc == 0, err
        assert f"module {V2}" in err
        lines = [line for line in out.splitlines() if "max=" in line]
        assert lines and all("max=3200  at row 15 col  0" in line for line in lines), out
        rc, out, _ = cli(["sensor", "stream", port, "--duration", "0.3", "--every", "0.1"], capsys)  # row-major
        assert rc == 0 and "at row 15 col  0" not in out
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()


@pytest.mark.parametrize("argv, words", [
    (["sensor", "stream", NO_PORT, "--module", "myrmex"], ["argument --module", "'myrmex'", V2]),
    (["sensor", "emulate", "--module", "v3"], ["argument --module", "'v3'"]),
    (["sensor", "stream", NO_PORT, "--module", V2, "--rows", "8"], ["--module", "--rows 8", "16x16"]),
    (["sensor", "emulate", "--module", V2, "--cols", "4"], ["--module", "--cols 4", "16x16"]),
    (["sensor", "record", NO_PORT, "--out", "{tmp}/x.tbr", "--module", V2, "--cell-order", "{tmp}/order.txt"],
     ["--module", "--cell-order", "give one"]),
    (["sensor", "stream", NO_PORT, "--registration", "{tmp}/reg.yaml"], ["--registration", "reg.yaml:1:1", "mapping"]),
])
def test_bad_module_options_end_in_one_error_line(argv, words, tmp_path, capsys):
    (tmp_path / "order.txt").write_text(" ".join(map(str, range(256))))
    (tmp_path / "reg.yaml").write_text("- 1\n")
    rc, out, err = cli([a.format(tmp=tmp_path) for a in argv], capsys)
    errors = [line for line in err.splitlines() if "error:" in line]
    assert rc == 2 and out == "" and len(errors) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in errors[0]
    assert NO_PORT not in err  # no port was opened
