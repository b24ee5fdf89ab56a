"""The 3-D view renders off screen into a picture that shows something."""

from pathlib import Path

import matplotlib.image as mpimg
import numpy as np

from tactile_bt import run_mission
from tactile_bt.cli import main

ROOT = Path(__file__).resolve().parents[2]


def test_view_renders_a_non_blank_png(tmp_path):
    run_mission(ROOT / "trees" / "cable_follow.yaml", ROOT / "sim" / "cable.yaml", duration=2.0, out=tmp_path)
    png = tmp_path / "render.png"
    assert main(["view", str(tmp_path), "--png", str(png)]) == 0
    image = mpimg.imread(png)[..., :3]
    assert image.shape[0] > 400 and image.shape[1] > 400
    # Not blank: many distinct colours, and a good share of pixels off the white background.
    assert len(np.unique((image * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 100
    assert np.mean(np.any(image < 0.95, axis=2)) > 0.2


def test_view_of_a_directory_without_a_report_says_so(tmp_path, capsys):
    assert main(["view", str(tmp_path), "--png", str(tmp_path / "x.png")]) == 2
    assert "report.json" in capsys.readouterr().err


def _orange_share(image: np.ndarray) -> float:
    """Share of pixels in the hue of the reconstructed surface (#e8b04a, shaded)."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return float(np.mean((r > 0.45) & (r - b > 0.3) & (g > 0.45 * r) & (g < 0.85 * r)))


def test_a_scan_mission_writes_its_surface_and_a_render_that_shows_it(tmp_path):
    """A short stripe scan of the box's top face: run writes surface.ply and render.png (off
    screen); the picture is not blank and shows the surface."""
    result = run_mission(ROOT / "trees" / "surface_scan_stripes.yaml", ROOT / "sim" / "scan_box.yaml", duration=4.0,
                         out=tmp_path, scan_region={"normal": [0, 0, 1], "max_angle_deg": 10})
    r = result.report["reconstruction"]
    assert r["method"] == "delaunay" and r["faces"] > 1000
    assert r["accuracy_m"] < 1e-3 and 0.1 < r["coverage"] <= 1.0 and r["longest_gap_s"] == 0.0
    for name in ("contacts.ply", "surface.ply", "render.png", "report.json"):
        assert (tmp_path / name).exists(), name
    image = mpimg.imread(tmp_path / "render.png")[..., :3]
    assert len(np.unique((image * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 100
    assert np.mean(np.any(image < 0.95, axis=2)) > 0.2
    with_surface = _orange_share(image)
    (tmp_path / "surface.ply").unlink()
    assert main(["view", str(tmp_path), "--png", str(tmp_path / "no_surface.png")]) == 0
    without = _orange_share(mpimg.imread(tmp_path / "no_surface.png")[..., :3])
    assert with_surface > 0.005 and with_surface > 3 * without


def test_view_without_a_display_says_so_and_points_to_png(tmp_path, capsys, monkeypatch):
    run_mission(ROOT / "trees" / "force_hold.yaml", ROOT / "sim" / "pen.yaml", duration=0.2, out=tmp_path)
    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no display" in err and f"--png {tmp_path / 'render.png'}" in err, err


def test_view_of_a_missing_directory_names_it(tmp_path, capsys):
    missing = tmp_path / "nothing"
    assert main(["view", str(missing), "--png", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {missing}: no such file or directory"), err
    assert f"is {tmp_path} the output" not in err


def test_the_render_keys_the_contacts_by_their_colour_bar_and_has_a_scale(tmp_path, monkeypatch):
    """No legend swatch of one colour for contacts coloured by a map; a ruler in mm for scale."""
    import pyvista as pv

    from tactile_bt.mission.view import scale_length_m

    seen = {}
    screenshot = pv.Plotter.screenshot

    def grab(self, *args, **kwargs):  # what the picture holds, before the plotter is closed
        legend = self.legend
        seen["legend"] = [legend.GetEntryString(i) for i in range(legend.GetNumberOfEntries())]
        seen["colour bars"] = list(self.scalar_bars.keys())
        seen["rulers"] = [a.GetTitle() for a in self.renderer.actors.values() if a.GetClassName() == "vtkAxisActor2D"]
        return screenshot(self, *args, **kwargs)

    monkeypatch.setattr(pv.Plotter, "screenshot", grab)
    run_mission(ROOT / "trees" / "cable_follow.yaml", ROOT / "sim" / "cable.yaml", duration=1.5, out=tmp_path)
    assert main(["view", str(tmp_path), "--png", str(tmp_path / "render.png")]) == 0
    assert seen["legend"] and not any("contact" in label for label in seen["legend"]), seen
    assert seen["colour bars"] == ["contacts: pressure (Pa)"]
    assert len(seen["rulers"]) == 1 and seen["rulers"][0].endswith(" mm")
    assert scale_length_m(0.7) == 0.2 and scale_length_m(0.05) == 0.01 and scale_length_m(0.001) == 0.002
