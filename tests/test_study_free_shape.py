"""The free-shape minimum-time reference (pathmotion/study/free_shape.py): its symbolic kinematics
against Pinocchio, its extrapolation on an analytic sequence, and two cases with a known answer
from pathmotion's own planner (delta = 0 at a corner: the time-optimal stop; a straight line:
the time-optimal chain), each verified on a dense resample."""

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("casadi", reason='the free-shape reference needs CasADi: pip install "pathmotion[optimal]"')

from pathmotion.errors import PathError, PathmotionError  # noqa: E402
from pathmotion.planning import PlanSettings, plan  # noqa: E402
from pathmotion.robot import fk, load_robot  # noqa: E402
from pathmotion.study import free_shape as fs  # noqa: E402

TURN = np.array([(0.4, -0.1, 0.45), (0.5, -0.1, 0.45), (0.5, 0.1, 0.45)])  # the 90 degree turn


def atlas_points(deg: float) -> np.ndarray:
    from pathmotion.study import atlas

    return atlas.corner_points(deg)


#: the case: the IRB140's official speeds with these accelerations [rad/s^2] (its 0.7196 s stop and the
#: iteration counts below are for them; the NLP is the same for any limits)
TURN_ACCELERATION = np.array([10.0, 10.0, 12.0, 20.0, 20.0, 25.0])


@pytest.fixture(scope="module")
def robot():
    irb140 = load_robot("irb140")
    return irb140.with_limits(replace(irb140.limits, acceleration=TURN_ACCELERATION))


def test_symbolic_kinematics_match_pinocchio(robot):
    f = fs.tcp_function(robot)
    rng = np.random.default_rng(7)
    for q in rng.uniform(robot.limits.lower, robot.limits.upper, (30, robot.n)):
        p, R = fk(robot, q)
        pc, Rc = f(q)
        np.testing.assert_allclose(np.asarray(pc).ravel(), p, atol=1e-12)
        np.testing.assert_allclose(np.asarray(Rc), R, atol=1e-12)


def test_extrapolation_is_exact_for_a_first_order_sequence():
    h = np.array([1.0, 0.5, 0.25, 0.125])
    value, err = fs.extrapolate(0.7 - 0.3 * h)
    assert value == pytest.approx(0.7, abs=1e-12)
    assert err == pytest.approx(0.3 * 0.125, rel=1e-9)
    value, _ = fs.extrapolate(0.5 + 0.2 * h ** 2)
    assert value == pytest.approx(0.5, abs=1e-12)


def test_extrapolation_of_a_non_monotone_sequence_is_the_finest_with_its_last_change():
    """Changes of opposite sign (e.g. the coarsest mesh in another local optimum): no order to fit."""
    value, err = fs.extrapolate([0.8598, 0.8508, 0.8513])
    assert value == pytest.approx(0.8513) and err == pytest.approx(0.0005)


@pytest.mark.parametrize("form", ["norm", "squared", "scaled"])
@pytest.mark.parametrize("radius", [1e-4, 1e-2])
def test_every_tube_form_is_the_capsule(form, radius):
    """The capsule's support function (analytic): its farthest point along a unit d (d_x > 0) is
    d . (end of its stretch) + r, whichever form the constraint takes."""
    ca = pytest.importorskip("casadi")
    line = fs.Polyline(np.array([(0.0, 0.0, 0.0), (0.1, 0.0, 0.0)]))
    ph = fs.Phase(0, 0.02, 0.08, radius)
    for direction in ((0.3, 0.8, 0.52), (1.0, 0.0, 0.0)):
        d = np.asarray(direction) / np.linalg.norm(direction)
        opti = ca.Opti()
        p = opti.variable(3)
        opti.set_initial(p, [0.05, 0.0, 0.0])
        fs._tube(fs._Constraints(opti), ca, p, line, ph, 0.05, form)
        opti.minimize(-ca.dot(ca.DM(d), p))
        opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-12, **fs.TUBE_IPOPT})
        sol = opti.solve()
        # IPOPT relaxes every bound by 1e-8 (bound_relax_factor): 1e-8 m for s and the norm form, but 1e-8 m^2
        # for the squared form, a tube of sqrt(r^2 + 1e-8): 41 % wider at r = 0.1 mm
        tol = 5e-8 + (np.sqrt(radius ** 2 + 1e-8) - radius if form == "squared" else 0.0)
        assert float(d @ np.asarray(sol.value(p)).ravel()) == pytest.approx(d[0] * ph.s_hi + radius, abs=tol)


def test_tube_phases_cover_each_segment(robot):
    line = fs.Polyline(TURN)
    whole = fs.tube_phases(line, 0.002)
    for j, L in enumerate(line.lengths):
        mine = [p for p in whole if p.segment == j]
        assert mine[0].s_lo == 0 and mine[-1].s_hi == pytest.approx(L)
        assert all(a.s_hi == pytest.approx(b.s_lo) for a, b in zip(mine, mine[1:]))
    confined = fs.tube_phases(line, 0.002, [(0.01, 0.02)])
    assert [(p.segment, p.radius) for p in confined] == [(0, 0.0), (0, 0.002), (1, 0.002), (1, 0.0)]
    assert confined[1].s_lo == pytest.approx(0.09) and confined[2].s_hi == pytest.approx(0.02)
    crowded = fs.tube_phases(line, 0.002, crowd=[(0.01, 0.02)])  # the whole tube on the confined one's phases
    assert [(p.segment, p.s_lo, p.s_hi, p.density) for p in crowded] == [(p.segment, p.s_lo, p.s_hi, p.density)
                                                                        for p in confined]
    assert all(p.radius == 0.002 for p in crowded)


def _check_verified(opt, delta, excess=0.05):
    """Limits hold in continuous time; the tube is imposed at points, so between them the TCP may
    leave it by ``excess`` x delta (less on finer meshes)."""
    v = opt.solutions[-1].verification
    assert v["max_velocity_ratio"] <= 1 + 1e-6 and v["max_acceleration_ratio"] <= 1 + 1e-6
    assert v["max_orientation_error_rad"] < 1e-5
    assert v["max_excess_m"] < excess * max(delta, 1e-3)


@pytest.mark.slow
def test_delta_zero_reproduces_the_time_optimal_stop(robot):
    _, stop = fs.stop_plan(robot, fs.Polyline(TURN))
    opt = fs.free_shape_optimum(robot, TURN, 0.0)
    assert opt.success, opt.status
    assert opt.duration == pytest.approx(stop.profile.duration, rel=2e-3)
    assert stop.profile.duration == pytest.approx(0.7196, abs=1e-4)  # the figure
    _check_verified(opt, 0.0)


@pytest.mark.slow
def test_straight_line_reproduces_the_planners_optimum(robot):
    """Two collinear segments: the NLP starts from the stop in the middle and must find the chain."""
    pts = np.array([(0.4, -0.1, 0.45), (0.5, -0.1, 0.45), (0.6, -0.1, 0.45)])
    path, stop = fs.stop_plan(robot, fs.Polyline(pts))
    chain = plan(path, robot, PlanSettings(start="zero", end="zero",
                                           limits={"use_velocity": True, "use_acceleration": True, "use_torque": False},
                                           baselines=False))
    assert stop.profile.duration > 1.05 * chain.profile.duration  # the guess is far from the answer
    opt = fs.free_shape_optimum(robot, pts, 0.0, meshes=(25, 50, 100))
    assert opt.success, opt.status
    assert opt.duration == pytest.approx(chain.profile.duration, rel=2e-3)
    _check_verified(opt, 0.0)


def _optimal_blend_motion(robot, deg: float, delta: float):
    """The atlas turn with its optimal blend: (points, shape, the blend's time-optimal PlanResult)."""
    from pathmotion.lift.constraint import lift
    from pathmotion.planning.blend_search import optimal_blends
    from pathmotion.study import atlas

    pts = atlas.corner_points(deg)
    task = atlas._task(pts)
    # the quintic (racing=False): its spans are a few mm, the case the warm start is for (the atlas starts a racing
    # line's corner-confined tube from the stop)
    best = optimal_blends(robot, task, delta, settings=atlas._settings(verify=False, baselines=False), cycles=1,
                          steps=3, racing=False)
    return pts, best.shapes[0], plan(lift(robot, best.path, original=task), robot, atlas._settings(baselines=False))


@pytest.mark.parametrize("deg", [90.0, 150.0])
def test_warm_start_from_a_blend_lies_in_the_corner_confined_tube(robot, deg):
    """The optimal blend's motion sampled per phase: phase boundaries in time order, every node in
    its own phase's capsule (the blend is within delta of the sharp path, on it outside its span).
    Past 90 degrees the path's start lies beyond the exit stretch's end along the exit segment: the
    exit stretch's end must be crossed after the corner (it was searched from t = 0, and at 150 deg
    / 1 mm the whole exit line fell into the 18 mm exit stretch, 0.18 m outside its tube)."""
    delta = 0.002
    pts, shape, warm = _optimal_blend_motion(robot, deg, delta)
    line = fs.Polyline(pts)
    phases = fs.tube_phases(line, delta, [(shape.entry, shape.exit)])
    guess = fs.guess_from_motion(robot, warm, line, phases, 60)
    t_b = guess.t[list(guess.breaks)]
    assert np.all(np.diff(t_b) > 0) and t_b[-1] == pytest.approx(warm.profile.duration)
    p = np.atleast_2d(fk(robot, guess.q)[0])
    for i, ph in enumerate(phases):
        nodes = p[guess.breaks[i]:guess.breaks[i + 1] + 1]
        assert np.max(fs._excess([ph], line, nodes)) < 1e-6 + 0.02 * delta, (i, ph)


def test_corner_confined_optimum_converges_from_the_blend_and_is_below_it(robot):
    """Both meshes converge (the cap was hit from the stop before); the optimum within the blend's
    own span is at most the blend's duration (the blend is one of its candidates) and verified; the
    whole tube started from it is at most it, mesh by mesh, and its nodes crowd like it. The nodes are
    compared on the first mesh only: a finer mesh may converge from the previous mesh's solution
    instead (free_shape.STARTS_WARM), resampled over that solution's own phase times, and which start
    IPOPT ends at depends on the process: on this input (the blend of the compiled Bezier arc length),
    the same blend and the same 25-interval solutions, the 50-interval whole tube converged from the
    first try in 69 iterations in a fresh process and needed the previous mesh's start inside the full
    test suite, twice)."""
    delta = 0.001
    pts, shape, warm = _optimal_blend_motion(robot, 90.0, delta)
    opt = fs.free_shape_optimum(robot, pts, delta, [(shape.entry, shape.exit)], meshes=(25, 50), warm=warm)
    assert opt.success, [s.status for s in opt.solutions]
    assert all(s.duration <= warm.profile.duration * (1 + 1e-3) for s in opt.solutions)
    _check_verified(opt, delta, excess=0.15)  # 50 intervals: 9 % of a 1 mm tube between the points
    # the whole tube contains the corner-confined one: from its solutions, on the same nodes, it ends at or below them
    whole = fs.free_shape_optimum(robot, pts, delta, meshes=(25, 50), warm=opt)
    assert whole.success, [s.status for s in whole.solutions]
    assert all(w.duration <= c.duration + 1e-6 for w, c in zip(whole.solutions, opt.solutions))
    assert whole.solutions[0].motion.breaks == opt.solutions[0].motion.breaks
    _check_verified(whole, delta, excess=0.15)


def test_whole_tube_at_a_tenth_of_a_millimetre_converges(robot):
    """The atlas, 30 degrees, 0.1 mm, 25 intervals: IPOPT hit its cap (800) here with the
    squared tube constraint; the norm form converges, below the stop (feasible for the NLP)."""
    from pathmotion.study import atlas

    pts = atlas.corner_points(30.0)
    _, stop = fs.stop_plan(robot, fs.Polyline(pts))
    opt = fs.free_shape_optimum(robot, pts, 1e-4, meshes=(25,))
    assert opt.success, [(s.status, s.iterations) for s in opt.solutions]
    assert opt.duration < stop.profile.duration
    _check_verified(opt, 1e-4, excess=0.2)  # 25 intervals: 0.12 mm outside a 0.1 mm tube between the points


def test_covered_stretches_are_absorbed_into_the_corner_stretches():
    """A stretch outside the corner spans that the corner stretches' capsules cover (the first 1.95 mm and the last
    0.2 um of 60 deg / 10 mm's racing line) joins them; longer ones, and every stretch of a delta = 0 tube, stay. The
    absorbed points lie in the capsule of the corner stretch they join (its cap), the independent check."""
    line = fs.Polyline(atlas_points(60.0))
    L = line.lengths
    spans = [(0.19805064846177695, 0.19999980000000003)]
    assert fs.effective_spans(L, 0.01, spans) == [(L[0], L[1])]
    for j, cap in ((0, fs.Phase(0, L[0] - spans[0][0], L[0], 0.01)), (1, fs.Phase(1, 0.0, spans[0][1], 0.01))):
        lo, hi = (0.0, L[0] - spans[0][0]) if j == 0 else (spans[0][1], L[1])
        s = np.linspace(lo, hi, 50)
        stretch = line.points[j] + s[:, None] * line.directions[j]
        assert np.max(fs._excess([cap], line, stretch)) <= 1e-12
    assert fs.effective_spans(L, 0.001, spans) == [(spans[0][0], L[1])]  # 1.95 mm > 1 mm: kept; 0.2 um: absorbed
    assert fs.effective_spans(L, 0.0, spans) == spans
    assert fs.effective_spans(L, 0.001, [(0.0164, 0.0182)]) == [(0.0164, 0.0182)]
    # between two corners: a stretch up to 2 delta long is split between them at its middle
    three = np.array([(0.0, 0.0, 0.0), (0.2, 0.0, 0.0), (0.2, 0.1, 0.0), (0.4, 0.1, 0.0)])
    assert fs.effective_spans(fs.Polyline(three).lengths, 0.01, [(0.05, 0.045), (0.04, 0.05)]) == [
        (0.05, pytest.approx(0.0525)), (pytest.approx(0.0475), 0.05)]
    assert [p.radius for p in fs.tube_phases(line, 0.01, spans)] == [0.01, 0.01]
    # a blend over both whole segments ends past the second by rounding (the joint stage's 60 deg / 10 mm blend):
    # clipped, the same tube as the whole segments; past it by more, still an error
    rounded = [(0.2, 0.2 + 7e-17)]
    assert fs.effective_spans(L, 0.01, rounded) == [(L[0], L[1])]
    assert fs.tube_phases(line, 0.01, rounded) == fs.tube_phases(line, 0.01, [(L[0], L[1])])
    with pytest.raises(PathError, match="do not fit"):
        fs.tube_phases(line, 0.01, [(0.2, 0.2 + 1e-6)])


def test_corner_confined_tube_with_covered_stretches_converges(robot):
    """60 deg / 10 mm, the racing line's spans: with a 1.95 mm and a 0.2 um stretch on the line the NLP hit its cap
    on every mesh from every start (their phases shrank to MIN_PHASE_DURATION); absorbed, it converges from the stop,
    below it, no phase near MIN_PHASE_DURATION, and its dense verification holds."""
    pts = atlas_points(60.0)
    spans = [(0.19805064846177695, 0.19999980000000003)]
    _, stop = fs.stop_plan(robot, fs.Polyline(pts))
    opt = fs.free_shape_optimum(robot, pts, 0.01, spans, meshes=(25,))
    assert opt.success, [(s.status, s.iterations) for s in opt.solutions]
    assert opt.duration < stop.profile.duration
    phase_times = np.diff(opt.solutions[0].motion.t[list(opt.solutions[0].motion.breaks)])
    assert np.all(phase_times > 10 * fs.MIN_PHASE_DURATION)
    _check_verified(opt, 0.01, excess=0.2)  # 25 intervals: 1.6 mm outside a 10 mm tube between the points


@pytest.mark.parametrize("meshes", [(), (0,), (25, 40), (25, 50, 99), ("x",)])
def test_meshes_the_extrapolation_cannot_use_are_refused_before_any_solve(robot, meshes):
    from pathmotion.errors import PathError

    with pytest.raises(PathError, match="e.g. 25,50,100"):
        fs.free_shape_optimum(robot, TURN, 0.001, meshes=meshes)


def test_multipliers_are_kept_and_given_by_constraint():
    """_Constraints against an analytic KKT point: min (x - 2)^2 + (y - 1)^2 s.t. x <= 1, y = 3 has the multipliers
    2 (x <= 1, active) and -4 (y = 3: grad f + lam grad g = 0); by key, whatever the order the constraints were added
    in. A start puts each given multiplier at its key's rows, 0 where a key is missing or its size differs."""
    ca = pytest.importorskip("casadi")
    opti = ca.Opti()
    x, y, z = opti.variable(), opti.variable(), opti.variable(2)
    con = fs._Constraints(opti)
    con(("z",), opti.bounded(-1.0, z, 1.0))
    con(("y",), y == 3)
    con(("x",), x <= 1)
    opti.minimize((x - 2) ** 2 + (y - 1) ** 2 + ca.sumsqr(z))
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-12})
    lam = con.multipliers(opti.solve().value(opti.lam_g))
    assert lam[("x",)] == pytest.approx([2.0], abs=1e-7) and lam[("y",)] == pytest.approx([-4.0], abs=1e-7)
    assert lam[("z",)] == pytest.approx([0.0, 0.0], abs=1e-7)
    start, matched = con.start({("y",): np.array([5.0]), ("x",): np.array([7.0, 8.0]), ("w",): np.array([1.0])})
    assert matched == 1 and list(start) == [0.0, 0.0, 5.0, 0.0]  # rows: z (2), y, x; x's size differs: 0


def test_a_start_with_its_own_multipliers_reconverges_at_once(robot):
    """Corner spans that cover both segments make the corner-confined NLP the whole tube's (the same phases, radius
    delta everywhere, the same constraints by key): started from its own solution with its multipliers (WARM_IPOPT),
    the whole tube maps every multiplier and IPOPT stops within a few iterations at the same optimum; the same start
    without its multipliers (0: IPOPT's warm start then has no dual point) takes more."""
    delta = 0.001
    L = fs.Polyline(TURN).lengths
    inner = fs.free_shape_optimum(robot, TURN, delta, [(L[0], L[1])], meshes=(12,))
    assert inner.success, inner.status
    keys = set(inner.solutions[0].multipliers)
    assert not any("on" in k for k in keys)  # radius delta everywhere: no constraint on the line
    whole = fs.free_shape_optimum(robot, TURN, delta, meshes=(12,), warm=fs.WithMultipliers(inner))
    sol, ref = whole.solutions[0], inner.solutions[0]
    assert whole.success, whole.status
    assert set(sol.multipliers) == keys and sol.motion.breaks == ref.motion.breaks
    assert sol.iterations <= 15, sol.iterations
    assert sol.duration == pytest.approx(ref.duration, abs=1e-8)
    for k in keys:
        np.testing.assert_allclose(sol.multipliers[k], ref.multipliers[k], rtol=1e-3, atol=1e-3)
    from pathmotion import defaults

    line = fs.Polyline(TURN)
    phases = fs.tube_phases(line, delta, None, inner.spans)
    zero = {k: np.zeros_like(v) for k, v in ref.multipliers.items()}
    cold = fs.solve_mesh(robot, line, phases, ref.motion, np.array(defaults.TOOL_DOWN_ROTATION), ipopt=fs.WARM_IPOPT,
                         multipliers=zero)
    assert cold.iterations > sol.iterations, (cold.iterations, sol.iterations)


def _stretch_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance [m] of the point p from the straight stretch from a to b."""
    u = float(np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
    return float(np.linalg.norm(p - a - u * (b - a)))


def test_feasible_bound_holds_the_tube_between_the_points_and_brackets_the_reference(robot):
    """At 25 intervals the TCP leaves a 1 mm tube between the points where the tube is imposed. The feasible bound
    re-solves in a shrunk tube until it does not: checked here at 2000 random times with Pinocchio's own forward
    kinematics and exact distances to the two segments (not the module's verify), its duration at or above the
    reference on the same mesh (a smaller tube), and at most the planner's time-optimal stop (a motion in every
    tube)."""
    import pinocchio as pin

    delta = 0.001
    opt = fs.free_shape_optimum(robot, TURN, delta, meshes=(25,))
    assert opt.success and opt.solutions[-1].verification["max_excess_m"] > 0  # the case needs the shrink
    bound = fs.feasible_bound(robot, TURN, delta, meshes=(25,), optimum=opt)
    assert 0 < bound.radius < delta and bound.solves >= 1
    assert bound.duration >= opt.solutions[-1].duration - 1e-9
    _, stop = fs.stop_plan(robot, fs.Polyline(TURN))
    assert bound.duration <= stop.profile.duration
    motion = bound.optimum.solutions[-1].motion
    t = np.sort(np.random.default_rng(7).uniform(motion.t[0], motion.t[-1], 2000))
    q, qd = fs._motion_at(motion)(t)
    model, data = robot.model, robot.model.createData()
    worst = -np.inf
    for qi in q:
        pin.framesForwardKinematics(model, data, qi)
        p = data.oMf[robot.tcp_frame_id].translation
        worst = max(worst, min(_stretch_distance(p, a, b) for a, b in zip(TURN[:-1], TURN[1:])) - delta)
    assert worst <= 1e-12
    assert np.max(np.abs(qd) / robot.limits.velocity) <= 1 + 1e-6
    assert np.max(np.abs(motion.u) / robot.limits.acceleration) <= 1 + 1e-6


def test_feasible_bound_refuses_a_coarse_mesh_that_leaves_the_line(robot):
    """The corner-confined tube holds the TCP on the line outside its spans. On 25 intervals the motion leaves the
    line between its points by 0.1 mm there, which no smaller tube fixes: the error says so at once (one solve, not
    FEASIBLE_SOLVES) and names the remedy."""
    opt = fs.free_shape_optimum(robot, TURN, 0.001, [(0.05, 0.1)], meshes=(25,))
    with pytest.raises(PathmotionError, match="held on the line.*give finer meshes") as err:
        fs.feasible_bound(robot, TURN, 0.001, [(0.05, 0.1)], meshes=(25,), optimum=opt)
    off = float(str(err.value).split("on the line by ")[1].split(" mm")[0]) * 1e-3
    assert off > fs.FEASIBLE_LINE_TOLERANCE  # the distance from the line, not the excess over the tolerance


INTERRUPTED_SOLVE = """
import os, signal, sys, threading
import casadi as ca
from pathmotion import cli
from pathmotion.study import free_shape as fs
sig = getattr(signal, sys.argv[1])
if sys.argv[2] == "cli":  # the command line's handlers (pathmotion.cli.main)
    signal.signal(signal.SIGINT, cli._interrupt)
    signal.signal(signal.SIGTERM, cli._interrupt)
handlers = (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM))
opti = ca.Opti()
x = opti.variable(3000)
opti.minimize(ca.sum1(100 * (x[1:] - x[:-1] ** 2) ** 2 + (1 - x[:-1]) ** 2))
opti.set_initial(x, -1.2)
opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "max_iter": 100000, "tol": 1e-300, "acceptable_iter": 0,
                                             "sb": "yes"})
threading.Timer(1.0, os.kill, args=(os.getpid(), sig)).start()
try:
    try:
        with fs._interrupts_kept():
            opti.solve()
        print("ran on after", opti.stats()["return_status"])
    except RuntimeError:
        print("ran on after", opti.stats()["return_status"])
except KeyboardInterrupt:
    print("interrupted after", opti.stats()["return_status"])
assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == handlers  # the handlers in place again
"""


@pytest.mark.parametrize("sig, handlers", [("SIGINT", "python"), ("SIGINT", "cli"), ("SIGTERM", "cli")])
def test_an_interrupt_during_a_solve_is_not_lost(tmp_path, sig, handlers):
    """CasADi catches the KeyboardInterrupt of a Ctrl-C (or of the command line's SIGTERM) inside IPOPT and returns
    the solve as failed: the references went on to the next start and `pathmotion corners` ran on to exit 0. Around
    each solve the interrupt is raised again: under Python's default SIGINT handler (a notebook) and under the command
    line's handlers. A real solve, interrupted 1 s in, in a subprocess."""
    import subprocess
    import sys

    script = tmp_path / "solve.py"
    script.write_text(INTERRUPTED_SOLVE)
    run = subprocess.run([sys.executable, str(script), sig, handlers], capture_output=True, text=True, timeout=300)
    out = (run.stdout.strip().splitlines() or [""])[-1]  # (after IPOPT's banner)
    if "Solve_Succeeded" in out or "Maximum_Iterations_Exceeded" in out:
        pytest.skip(f"the solve ended before the signal on this machine: {out}")
    assert out.startswith("interrupted after") and run.returncode == 0, (out, run.stderr[-2000:])
