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
