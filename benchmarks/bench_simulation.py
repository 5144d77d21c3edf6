"""Real-time factor of the closed-loop simulation (simulated seconds per wall-clock second).

One closed-loop run of the IRB140 (6 joints) along a joint spline at the 4 ms controller sample time,
orbital controller, plant = RK4 with defaults.PLANT_SUBSTEPS sub-steps per sample. The peer, measured
in the same run: the same applied torque profile (zero-order hold per sample) integrated by a plain
loop that calls Pinocchio's ABA inside scipy's solve_ivp (RK45, rtol 1e-6, one call per sample, as a
straightforward closed-loop simulation would do it). Second peer (when ``mujoco`` is installed): MuJoCo
stepping the same arm (its own parse of the same URDF, RK4, same step) under a plain joint PD
(tau = Kp (q_ref - q) + Kd (qd_ref - qd), Kp/Kd from defaults.PD_BANDWIDTH/PD_DAMPING and the diagonal of
M at the start), a Python loop calling mj_step per sample along the states the orbital run recorded.
Loop-only rows time the sample loop alone; end-to-end rows are one simulate() call in a warm process with its
set-up inside (our orbital design: path table + sampled Riccati gains, built into an empty cache folder or read
from the disk cache; MuJoCo: parsing the URDF into an MjModel), not the CLI's imports, plan or figures. The target
is >= 20x real time end to end with the cache empty. Every row gives the median and the range (min-max) of
``repeat`` runs, wall clock and process CPU time (a shared machine inflates the wall clock by about its load
average / 2; the load before and after is printed).
Run: python benchmarks/bench_simulation.py [repeat]
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

from pathmotion import api, defaults
from pathmotion.control import OrbitalDesign, OrbitalGains, PathTable, design_cache
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning.profile import Profile
from pathmotion.robot import load_robot
from pathmotion.scenarios import scenario_path
from pathmotion.simulation import Plant, SimulationSettings, polish_projection, simulate

#: Shipped scenarios whose simulate stage is timed too (1-1.5 s motions on lifted task paths).
SCENARIOS = ("corner_g2", "circle_zero")
WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                      [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                      [1.0, 0.1, 0.2, -0.2, 0.4, 1.2],
                      [1.4, -0.2, 0.4, 0.1, 0.9, 1.6]])


class Timing:
    """Wall-clock and process CPU times [s] of ``repeat`` runs of one row."""

    def __init__(self, wall: list[float], cpu: list[float]):
        self.wall, self.cpu = np.array(wall), np.array(cpu)

    def row(self, label: str, simulated: float | None = None) -> str:
        """label, median [min-max] wall and CPU in ms, and x real time of ``simulated`` seconds (median [range])."""
        text = f"{label:46s}{_ms(self.wall)}   CPU {_ms(self.cpu)}"
        if simulated is not None:
            text += f"   -> {_factor(simulated, self.wall)} x real time (CPU {_factor(simulated, self.cpu)} x)"
        return text


def _ms(seconds: np.ndarray) -> str:
    return f"{np.median(seconds) * 1e3:7.1f} ms [{seconds.min() * 1e3:6.1f}-{seconds.max() * 1e3:6.1f}]"


def _factor(simulated: float, seconds: np.ndarray) -> str:
    return f"{simulated / np.median(seconds):5.1f} [{simulated / seconds.max():5.1f}-{simulated / seconds.min():5.1f}]"


def timed(fn, repeat: int, before=None) -> tuple[Timing, object]:
    """(Timing of ``repeat`` calls of fn, the last result); ``before`` runs untimed before each call."""
    wall, cpu, out = [], [], None
    for _ in range(repeat):
        if before is not None:
            before()
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return Timing(wall, cpu), out


def end_to_end(robot, path, profile, settings, repeat) -> tuple[Timing, Timing]:
    """simulate() with its set-up (path table + orbital design) inside: (cold: the cache folder emptied before
    each run, warm: a cache hit)."""
    with tempfile.TemporaryDirectory() as folder:
        os.environ[design_cache.ENV] = folder

        def empty():
            for f in Path(folder).iterdir():
                f.unlink()

        def run():
            return simulate(robot, path, profile, "orbital", settings)

        cold, _ = timed(run, repeat, before=empty)
        warm, _ = timed(run, repeat)
    os.environ.pop(design_cache.ENV)
    return cold, warm


def main(repeat: int = 7) -> None:
    load0 = os.getloadavg()
    robot = load_robot("irb140")
    path = SplineJointPath.from_waypoints(WAYPOINTS)
    v, a = 0.9, 2.0
    ta = v * v / (2 * a)
    profile = Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))
    ts = defaults.SAMPLE_TIME
    settings = SimulationSettings(sample_time=ts)
    sampling = (ts, int(settings.realism.delay)) if settings.sampled_design else (None, 0)  # the default design
    def build():
        return OrbitalDesign.build(PathTable.from_path(path), profile, OrbitalGains(), *sampling)

    build()  # warm-up (numba cache, the BLAS thread controller)
    t_design, design = timed(build, repeat)
    simulate(robot, path, profile, "orbital", settings, design=design)  # warm-up (numba cache, imports)
    t_loop, result = timed(lambda: simulate(robot, path, profile, "orbital", settings, design=design), repeat)
    t_cold, t_warm = end_to_end(robot, path, profile, settings, repeat)
    simulated = result.t[-1] + ts

    # plant alone, same torques
    plant = Plant.from_robot(robot)
    q0, qd0 = result.q[0], result.qd[0]

    def own_plant():
        q, qd = q0, qd0
        for tau in result.tau:
            q, qd = plant.step(q, qd, tau, ts, settings.substeps)
        return q

    t_plant, q_own = timed(own_plant, repeat)

    model, data = robot.model, robot.model.createData()
    n = robot.n

    def peer():
        x = np.concatenate([q0, qd0])
        for tau in result.tau:
            sol = solve_ivp(lambda _, s: np.concatenate([s[n:], pin.aba(model, data, s[:n], s[n:], tau)]),
                            (0.0, ts), x, method="RK45", rtol=1e-6, atol=1e-9)
            x = sol.y[:, -1]
        return x[:n]

    t_peer, q_peer = timed(peer, repeat)
    mujoco_rows = mujoco_peer(robot, result, settings, repeat)
    scenario_rows = [row for name in SCENARIOS for row in scenario_peer(name, repeat)]
    load1 = os.getloadavg()
    print(f"load average (1, 5 min) before {load0[0]:.2f}, {load0[1]:.2f} / after {load1[0]:.2f}, {load1[1]:.2f} "
          f"({os.cpu_count()} cores); median [min-max] of {repeat} runs")
    print(f"simulated time {simulated:.3f} s ({len(result.t)} samples of {ts * 1e3:g} ms)")
    print(t_design.row("orbital design (table + sampled Riccati), once"))
    print(t_plant.row(f"plant alone, RK4 x {settings.substeps}, same torques", simulated))
    print(t_peer.row("peer: ABA in solve_ivp (RK45), same torques", simulated))
    print(f"ratio plant / peer (medians)                  {np.median(t_peer.wall) / np.median(t_plant.wall):6.2f}")
    print(f"final-state difference own plant vs peer      {np.max(np.abs(q_own - q_peer)):.2e} rad")
    print(t_cold.row("end to end, set-up built (cache empty)", simulated))
    print(t_warm.row("end to end, set-up from the disk cache", simulated))
    print(t_loop.row("loop only (design given)", simulated))
    for label, timing in mujoco_rows:
        print(timing.row(label, simulated))
    for label, timing, seconds in scenario_rows:
        print(timing.row(label, seconds))
    wall, cpu = simulated / np.median(t_cold.wall), simulated / np.median(t_cold.cpu)
    print(f"target >= 20x real time end to end (cache empty), medians: wall clock {wall:.1f}x "
          f"{'met' if wall >= 20 else 'NOT met'}, CPU time {cpu:.1f}x {'met' if cpu >= 20 else 'NOT met'}")
    for label, timing, seconds in scenario_rows:
        if "cache empty" in label:
            factor = seconds / np.median(timing.cpu)
            print(f"  {label.split(' (')[0]}, cache empty: CPU time {factor:.1f}x {'met' if factor >= 20 else 'NOT met'}")


def scenario_peer(name: str, repeat: int) -> list[tuple[str, Timing, float | None]]:
    """(label, Timing, simulated seconds or None) rows of the simulate stage of ``pathmotion simulate scenarios/NAME.toml``
    (api.simulate_scenario after the plan, which is not timed): cache empty, and from the disk cache. A shipped
    task path is lifted by inverse kinematics, so its path table costs more than the test spline's; two parts of the
    cold run are timed alone: the path table and the exact re-projection of the run's samples after it."""
    setup = api.load(scenario_path(name))
    plan_result = api.plan_scenario(setup)
    with tempfile.TemporaryDirectory() as folder:
        os.environ[design_cache.ENV] = folder

        def empty():
            for f in Path(folder).iterdir():
                f.unlink()

        cold, sim = timed(lambda: api.simulate_scenario(setup, plan_result), repeat, before=empty)
        warm, _ = timed(lambda: api.simulate_scenario(setup, plan_result), repeat)
    os.environ.pop(design_cache.ENV)
    seconds = float(sim.t[-1] + sim.sample_time)
    table, _ = timed(lambda: PathTable.from_path(setup.path), repeat)  # parts of the cold set-up and the metrics
    polish, _ = timed(lambda: polish_projection(setup.path, sim.q, sim.theta), repeat)
    return [(f"{name} ({seconds:.2f} s), simulate stage, cache empty", cold, seconds),
            (f"{name} ({seconds:.2f} s), simulate stage, from the cache", warm, seconds),
            ("  of it: path table of the lifted path", table, None),
            ("  of it: re-projection after the run", polish, None)]


def mujoco_peer(robot, result, settings, repeat: int) -> list[tuple[str, Timing]]:
    """(label, Timing) rows for MuJoCo: the plant alone on the same torques, and MuJoCo + a plain PD
    loop-only and end to end (model build included); [] when mujoco is not installed."""
    try:
        import mujoco
    except ImportError:
        print("mujoco not installed: MuJoCo peer skipped (pip install \"pathmotion[mujoco]\")")
        return []
    from pathmotion.simulation.mujoco_plant import MujocoPlant, build_model

    ts, substeps = settings.sample_time, settings.substeps
    plant = MujocoPlant.from_robot(robot)

    def replay():
        q, qd = result.q[0], result.qd[0]
        for tau in result.tau:
            q, qd = plant.step(q, qd, tau, ts, substeps)
        return q

    t_replay, _ = timed(replay, repeat)
    w, zeta = defaults.PD_BANDWIDTH, defaults.PD_DAMPING
    inertia = np.diag(pin.crba(robot.model, robot.data, result.q[0]))
    kp, kd = w * w * inertia, 2.0 * zeta * w * inertia
    q_ref, qd_ref = result.q, result.qd

    def pd_loop(model):
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:] = q_ref[0], qd_ref[0]
        for k in range(len(q_ref)):
            data.qfrc_applied[:] = kp * (q_ref[k] - data.qpos) + kd * (qd_ref[k] - data.qvel)
            mujoco.mj_step(model, data, substeps)
        return data.qpos.copy()

    model = build_model(robot, timestep=ts / substeps)
    t_loop, _ = timed(lambda: pd_loop(model), repeat)
    t_e2e, _ = timed(lambda: pd_loop(build_model(robot, timestep=ts / substeps)), repeat)
    return [(f"MuJoCo plant alone, RK4 x {substeps}, same torques", t_replay),
            ("MuJoCo + plain PD, loop only", t_loop),
            ("MuJoCo + plain PD, end to end (URDF parse)", t_e2e)]


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
