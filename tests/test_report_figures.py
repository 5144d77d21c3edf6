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


def test_joint_positions_are_drawn_against_their_range_as_in_the_report():
    """The PNG and the report scale q alike: -1 at the lower end of the range, +1 at the upper, 0 at its centre."""
    from pathmotion.report.tables import in_range

    q = np.array([[-1.0, 0.0], [1.0, 0.5]])
    np.testing.assert_allclose(in_range(q, [-1.0, -2.0], [1.0, 2.0]), [[-1.0, 0.0], [1.0, 0.25]])
    np.testing.assert_allclose(in_range([[0.3]], [0.3], [1.3]), [[-1.0]])  # an asymmetric range


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


def test_a_phase_plane_curve_above_the_plot_everywhere_is_named_so_and_not_drawn():
    cols = _phase_cols()
    cols["theta_dot_max_pointwise"] = cols["theta_dot_optimal"] + 100.0  # far above the plot's top
    ax = figures.phase_plane(cols, {"path_kind": "task", "duration_s": 1.0})
    labels = {line.get_label(): line for line in ax.get_lines()}
    off = labels["all limits (planner's curve) (above the plot everywhere)"]
    assert len(off.get_xdata()) == 0  # only in the legend
    assert len(labels["controllable bound"].get_xdata()) == len(cols["theta"])  # on the scale: drawn
    figures.plt.close(ax.figure)


def test_a_multi_line_title_stays_above_the_axes():
    fig, axes = figures.plt.subplots(2, 1, figsize=(9, 6))
    figures._title(fig, "corner_max: joint tracking (orbital) - tracking FAILED: " + "the TCP left the path " * 12)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert fig._suptitle.get_window_extent(renderer).y0 >= axes[0].get_window_extent(renderer).y1
    figures.plt.close(fig)


def _captured(monkeypatch):
    """Replace the study figures' saver: keeps the figure instead of writing it."""
    from pathmotion.study import figures as study_figures

    kept = []
    monkeypatch.setattr(study_figures, "_save", lambda fig, path: kept.append(fig) or path)
    return kept


def test_tdelta_draws_the_stop_across_each_panel_and_keeps_the_legend_off_the_data(monkeypatch, tmp_path):
    from pathmotion.study.atlas import tdelta_figure

    kept = _captured(monkeypatch)
    rows = [dict(angle_deg=90.0, tolerance_m=0.005, stop_s=0.87, g2_s=0.82, optimal_s=0.80)]  # one tolerance
    tdelta_figure(rows, tmp_path / "t.png")
    ax = kept[0].axes[0]
    stop = [line for line in ax.get_lines() if line.get_label() == "stop at the corner"]
    assert stop and np.allclose(stop[0].get_ydata(), 0.87)  # a horizontal line, visible with a single tolerance
    kept[0].canvas.draw()
    renderer = kept[0].canvas.get_renderer()
    assert ax.get_legend().get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1


def test_tradeoff_legend_tells_an_error_from_lost_tracking(monkeypatch, tmp_path):
    from pathmotion.study.figures import tradeoff_figure

    kept = _captured(monkeypatch)
    rows = [{"max_sharp_deviation_m": 0.01, "cycle_time_s": 1.3, "tracking_ok": True, "error": None},
            {"max_sharp_deviation_m": 0.02, "cycle_time_s": None, "tracking_ok": False, "error": None},
            {"error": "PathError: a transition circle of radius 0.06 m does not fit"}]
    tradeoff_figure(rows, [0], None, tmp_path / "t.png")
    texts = [t.get_text() for t in kept[0].axes[0].get_legend().get_texts()]
    assert "1 point(s) with an error, no result (not shown)" in texts
    assert "1 point(s) lost tracking (not shown)" in texts
