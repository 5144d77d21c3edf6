"""The MoveIt reproduction of benchmarks/bench_moveit_peer.py: its quintic playback and its Ruckig loop
checked on cases whose answer is known."""

import numpy as np
import pytest

pytest.importorskip("ruckig", reason="the peer benchmark needs ruckig (dev extra: pip install -e '.[dev]')")
pytest.importorskip("toppra", reason="the peer benchmark needs toppra (dev extra)")

from benchmark_modules import load_benchmark  # noqa: E402

bench = load_benchmark("bench_moveit_peer")


def test_quintic_playback_reproduces_a_quintic_exactly():
    """One quintic per joint over the whole motion: the piecewise quintic through its samples is itself."""
    coef = np.random.default_rng(0).normal(size=(6, 2))  # (power, joint)
    times = np.array([0.0, 0.13, 0.4, 0.55, 0.9])

    def poly(t, d):
        out = np.zeros((len(t), 2))
        for p in range(d, 6):
            out += np.prod(np.arange(p - d + 1, p + 1)) * coef[p] * t[:, None] ** (p - d)
        return out

    s = bench.Smoothed(times, poly(times, 0), poly(times, 1), poly(times, 2), [], 1.0, True)
    m = bench.quintic(s)
    assert m.duration == pytest.approx(0.9)
    for got, d in ((m.q, 0), (m.qd, 1), (m.qdd, 2)):
        assert np.allclose(got, poly(m.t, d), atol=1e-9)


def test_ruckig_loop_joins_segments_through_the_waypoints_of_a_feasible_motion():
    """Waypoints sampled from a jerk-limited motion, smoothed under 1.5x its limits: no stretch (each
    piece of the motion is a feasible, not time-optimal, way between its ends), every Ruckig segment
    ends exactly in the next waypoint's state and is no longer than the piece it replaces, and the joined
    playback has their total duration."""
    from ruckig import InputParameter, Ruckig, Trajectory

    vmax, amax, jmax = np.array([2.0, 1.0]), np.array([4.0, 3.0]), np.array([30.0, 20.0])
    inp = InputParameter(2)
    inp.current_position, inp.target_position = [0.0, 0.2], [1.5, -0.4]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = vmax.tolist(), amax.tolist(), jmax.tolist()
    traj = Trajectory(2)
    Ruckig(2).calculate(inp, traj)
    times = np.append(np.arange(0.0, traj.duration, 0.05), traj.duration)
    p, v, a = (np.array([traj.at_time(t)[k] for t in times]) for k in range(3))
    s = bench.moveit_ruckig(times, p, v, a, 1.5 * vmax, 1.5 * amax, 1.5 * jmax)
    assert s.ok and s.factor == 1.0
    for k, seg in enumerate(s.segments):
        end = np.array(seg.at_time(seg.duration)[:3])
        assert np.allclose(end, [p[k + 1], v[k + 1], a[k + 1]], atol=1e-8)
        assert seg.duration <= times[k + 1] - times[k] + 1e-9
    m = bench.ruckig_segments(s)
    assert m.duration == pytest.approx(sum(seg.duration for seg in s.segments), rel=1e-12)
    assert np.allclose(m.q[0], p[0]) and np.allclose(m.q[-1], p[-1], atol=1e-9)


def test_a_target_ruckig_cannot_hold_is_stretched_as_moveit_does():
    """A waypoint at full speed that is slowing down cannot be reached (just before it the joint was faster
    than its limit): MoveIt divides its velocity by the growing factor (1.1 per failure) and stretches
    its duration from the original until Ruckig succeeds."""
    vmax, amax, jmax = np.array([1.0]), np.array([2.0]), np.array([10.0])
    times = np.array([0.0, 0.5, 1.0])
    q = np.array([[0.0], [0.3], [0.6]])
    qd = np.array([[0.0], [1.0], [0.0]])
    qdd = np.array([[0.0], [-2.0], [0.0]])
    s = bench.moveit_ruckig(times, q, qd, qdd, vmax, amax, jmax)
    assert s.factor > 1.0
    steps = round(np.log(s.factor) / np.log(bench.DURATION_EXTENSION_FRACTION))
    assert s.factor == pytest.approx(bench.DURATION_EXTENSION_FRACTION ** steps)
    assert np.all(np.abs(s.qd[1]) < 1.0)  # slowed below the limit it had to hold
    assert s.times[1] > 0.5  # the failed segment got longer
    assert np.allclose(s.q, q)  # MoveIt never moves a waypoint
