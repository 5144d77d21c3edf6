"""The PNG figures of report/figures.py: labels, units and titles read from the folder's files."""

import numpy as np
import pytest

from pathmotion.report import figures


def _phase_cols():
    th = np.linspace(0.0, 0.6, 50)
    opt = np.sin(np.pi * th / 0.6) + 0.01
    return {"theta": th, "theta_dot_optimal": opt, "theta_dot_max_pointwise": opt + 1,
            "theta_dot_controllable": opt + 0.5}


@pytest.mark.parametrize("kind, x_unit, y_unit", [("task", "[m]", "[m/s]"), ("joint", "[-]", "[1/s]")])
def test_phase_plane_units_follow_the_path_kind_and_the_title_names_the_scenario(kind, x_unit, y_unit):
    ax = figures.phase_plane(_phase_cols(), {"path_kind": kind, "scenario": "corner_g2", "duration_s": 1.0})
    assert ax.get_xlabel().endswith(x_unit) and ax.get_ylabel().endswith(y_unit)
    assert "corner_g2" in ax.get_title()
    figures.plt.close(ax.figure)


def test_joint_positions_are_drawn_against_their_range():
    q = np.array([[-1.0, 0.0], [1.0, 0.5]])
    lim = {"lower": [-1.0, -2.0], "upper": [1.0, 2.0]}
    np.testing.assert_allclose(figures._in_range(q, lim), [[0.0, 0.5], [1.0, 0.625]])


def test_legends_sit_outside_the_axes_and_long_titles_wrap():
    ax = figures.phase_plane(_phase_cols(), {"path_kind": "task", "scenario": "x" * 200, "duration_s": 1.0})
    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert ax.get_legend().get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1
    assert all(len(line) <= figures.TITLE_WIDTH for line in ax.get_title().splitlines())
    figures.plt.close(fig)


def test_tradeoff_labels_never_overlap_each_other_or_a_point(tmp_path):
    from pathmotion.study import figures as sf

    plt = sf._plt()
    fig, ax = plt.subplots()
    xs = np.array([10.0, 10.1, 10.2, 19.0, 19.05, 30.0])
    ys = np.array([1.40, 1.401, 1.399, 1.35, 1.351, 1.30])
    ax.scatter(xs, ys)
    placed = sf._place_labels(ax, [(f"point {k}", x, y) for k, (x, y) in enumerate(zip(xs, ys))], fontsize=8)
    renderer = fig.canvas.get_renderer()
    boxes = [a.get_window_extent(renderer) for a in placed]
    assert len(placed) >= 4
    assert not any(boxes[i].overlaps(boxes[j]) for i in range(len(boxes)) for j in range(i))
    marks = [ax.transData.transform(p) for p in zip(xs, ys)]
    assert not any(b.contains(*m) for b in boxes for m in marks)
    plt.close(fig)


def test_corner_view_is_framed_on_the_curves_and_study_panels_share_time():
    from pathmotion.study import figures as sf

    corner = np.array([0.5, 0.0, 0.5])
    tcp = np.column_stack([np.linspace(0.49, 0.5, 50), np.linspace(0.0, -0.004, 50), np.full(50, 0.5)])
    far = np.array([[0.9, 0.9, 0.5]])  # outside the window: ignored
    (x0, x1), (y0, y1) = sf._frame([("a", {"tcp": np.vstack([tcp, far])})], None, corner, 0.05)
    assert x0 < 0.49 and x1 > 0.5 and y0 < -0.004 and y1 > 0.0
    assert x1 - x0 < 0.012 and y1 - y0 < 0.012  # framed on the curve, not on the +-50 mm window
    fig, axes = sf._panels(3)
    assert axes[0].get_shared_x_axes().joined(axes[0], axes[2])
    sf._plt().close(fig)
