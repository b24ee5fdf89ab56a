"""The 3-D view renders off screen into a picture that shows something."""

from pathlib import Path

import matplotlib.image as mpimg
import numpy as np

from tactile_bt import run_mission
from tactile_bt.cli import main

ROOT = Path(__file__).resolve().parent.parent


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
