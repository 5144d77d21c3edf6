"""The fast search's rise out of the corner's plane where the tolerance leaves room (FAST_RISE_PLANS)."""

from pathmotion.planning import blend_search as bs
from pathmotion.robot import load_robot
from pathmotion.study.atlas import _settings, _task, corner_points


def test_the_rise_needs_a_tolerance_of_a_share_of_the_shorter_segment():
    """The atlas' lines are 0.2 m: the rise has room at 5 mm, not at 1 mm."""
    task = _task(corner_points(30.0))
    share = bs.FAST.rise_tolerance_share
    assert share > 0.0 and bs.FAST.rise_plans > 0
    room = [bs._rise_room(bs._Objective(None, task, {}, 0, tol, None, None), share) for tol in (0.001, 0.005)]
    assert room == [False, True]


def test_the_fast_search_rises_out_of_the_plane_at_a_wide_shallow_corner():
    """The atlas' 30 deg corner at 5 mm: the thorough search's blend (0.37123 s, benchmarks/atlas_thorough_durations.json)
    rises out of the corner's plane; the fast search without the rise ends at 0.37312 s, with it within 0.2 % of the
    thorough one."""
    best = bs.optimal_blends(load_robot("irb140"), _task(corner_points(30.0)), 0.005,
                             settings=_settings(False, verify=False, baselines=False), search=bs.FAST)
    assert best.duration < 0.3720
    assert not best.shapes[0].planar
