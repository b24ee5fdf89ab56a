"""errors.png (plot_errors): every trace visible, and a panel that would be empty says why."""

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

from tactile_bt.mission.outputs import plot_errors  # noqa: E402

N = 500


def _result(**series):
    t = np.arange(N) * 0.004
    nan = np.full(N, np.nan)
    log = {"t": t, "pressure_raw_pa": np.full(N, 2000.0), "error_pressure_pa": np.zeros(N),
           "error_cop_x_px": nan, "error_cop_y_px": nan, "cop_x_px": nan, "cop_y_px": nan,
           "error_orientation_rad": nan, "orientation_rad": nan}
    log.update(series)
    summary = SimpleNamespace(tree="t.yaml", scene="s.yaml", status="completed", seed=0)
    return SimpleNamespace(log=log, summary=summary)


def _pixels_near(fig, ax, colour, tol=40) -> int:
    fig.canvas.draw()
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(int)
    (x0, y0), (x1, y1) = ax.get_window_extent().get_points().astype(int)
    height = image.shape[0]
    panel = image[height - y1:height - y0, x0:x1]
    rgb = np.array(matplotlib.colors.to_rgb(colour)) * 255
    return int(np.sum(np.all(np.abs(panel - rgb) < tol, axis=-1)))


def test_cop_x_stays_visible_where_it_coincides_with_cop_y():
    same = 0.5 * np.sin(np.linspace(0, 6, N))
    fig = plot_errors(_result(error_cop_x_px=same, error_cop_y_px=same.copy()))
    x_pixels, y_pixels = _pixels_near(fig, fig.axes[1], "C0"), _pixels_near(fig, fig.axes[1], "C1")
    assert y_pixels > 200 and x_pixels > 0.5 * y_pixels, (x_pixels, y_pixels)


def test_a_feature_undefined_in_most_cycles_says_so_instead_of_an_empty_panel():
    orientation = np.full(N, np.nan)
    orientation[100:104] = 0.01  # a line for a moment, then a patch with no dominant axis
    fig = plot_errors(_result(error_orientation_rad=orientation))
    notes = [t.get_text() for t in fig.axes[2].texts]
    assert any("orientation undefined in 99%" in n and "no dominant axis" in n for n in notes), notes


def test_a_feature_no_leaf_controlled_shows_its_measured_values():
    fig = plot_errors(_result(cop_x_px=np.full(N, 7.0), cop_y_px=np.full(N, 8.0)))
    assert fig.axes[1].get_ylabel() == "COP (px)" and "no leaf controlled it" in fig.axes[1].get_title(loc="left")
    assert [line.get_ydata()[0] for line in fig.axes[1].lines if len(line.get_ydata()) == N] == [7.0, 8.0]
