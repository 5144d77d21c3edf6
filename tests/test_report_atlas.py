"""The corner atlas' section of the HTML report (report/atlas.py): found in an atlas folder (and its
per-point sweep folder not listed apart), its table and its two figures from a handmade corners.csv."""

from __future__ import annotations

import re

from pathmotion.report.atlas import gain_figure, tdelta_figure
from pathmotion.report.discovery import discover
from pathmotion.report.html import build_report
from pathmotion.study.atlas import ATLAS_COLUMNS
from pathmotion.study.sweep import write_tables


def _rows():
    rows = []
    for angle in (60.0, 90.0):
        for tol, opt in ((0.001, 0.84), (0.01, 0.74)):
            rows.append({"angle_deg": angle, "tolerance_m": tol, "status": "ok", "stop_s": 0.873, "circle_s": opt + 0.05,
                         "g2_s": opt + 0.01, "optimal_s": opt, "free_shape_optimum_s": opt - 0.05,
                         "corner_optimum_s": opt - 0.005, "industrial_zone_s": 1.6, "gain_vs_stop": 1 - opt / 0.873,
                         "closed_loop_ok": True, "torque": True, "torque_reserve": 0.2})
    rows.append({"angle_deg": 90.0, "tolerance_m": 0.05, "status": "error",
                 "error": "PathError: tolerance 0.05 m is too large; give a tolerance below 0.0289 m"})
    rows[1]["status"] = "corner_optimum: NLP not converged (Maximum_Iterations_Exceeded)"
    rows[1]["corner_optimum_s"] = None
    return rows


def test_atlas_folder_is_one_section_with_its_table_and_figures(tmp_path):
    atlas = tmp_path / "corners"
    (atlas / "points_sweep").mkdir(parents=True)
    rows = _rows()
    write_tables(atlas, rows, list(ATLAS_COLUMNS), stem="corners")
    write_tables(atlas / "points_sweep", [{"angle_deg": 60.0}], ["angle_deg"])  # the sweep machinery's own table
    found = discover(tmp_path)
    assert [(r.kind, r.path.name) for r in found] == [("atlas", "corners")]
    page = build_report(tmp_path).read_text()
    assert "Corner atlas: corners" in page
    assert re.search(r'data-figures="2"', page)
    assert page.count("<tr>") >= len(rows) + 1  # header + every row
    assert "NLP not converged" in page and "give a tolerance below 0.0289 m" in page
    assert "<th>torque limits</th>" in page  # the atlas says whether it planned within the torque limits
    assert "<th>torque reserve [%]</th>" in page and "<td>20</td>" in page  # and with what reserve


def test_figures_draw_every_method_present():
    rows = [r for r in _rows() if not r.get("error")]
    fig = tdelta_figure(rows)
    names = {t.name for t in fig.data}
    assert "60 deg: optimal blend" in names and "90 deg: whole-tube optimum" in names
    optimal_90 = next(t for t in fig.data if t.name == "90 deg: optimal blend")
    assert list(optimal_90.x) == [1.0, 10.0] and list(optimal_90.y) == [0.84, 0.74]
    corner_60 = next(t for t in fig.data if t.name == "60 deg: corner-confined optimum")
    assert list(corner_60.x) == [1.0]  # the unconverged (10 mm) row is left out, not drawn as a number
    gain = gain_figure(rows)
    first = next(t for t in gain.data if t.name == "1 mm: optimal blend")
    assert list(first.x) == [60.0, 90.0]
    assert abs(first.y[0] - 100 * (1 - 0.84 / 0.873)) < 1e-9
