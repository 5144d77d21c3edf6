"""Real-time factor of the closed-loop simulation (simulated seconds per wall-clock second).

One closed-loop run of the IRB140 (6 joints) along a joint spline at the 4 ms controller sample time,
orbital controller, plant = RK4 with defaults.PLANT_SUBSTEPS sub-steps per sample. The peer, measured
in the same run: the same applied torque profile (zero-order hold per sample) integrated by a plain
loop that calls Pinocchio's ABA inside scipy's solve_ivp (RK45, rtol 1e-6, one call per sample, as a
straightforward closed-loop simulation would do it). Second peer (when ``mujoco`` is installed): MuJoCo
stepping the same arm (its own parse of the same URDF, RK4, same step) under a plain joint PD
(tau = Kp (q_ref - q) + Kd (qd_ref - qd), Kp/Kd from defaults.PD_BANDWIDTH/PD_DAMPING and the diagonal of
M at the start), a Python loop calling mj_step per sample along the states the orbital run recorded.
Loop-only rows time the sample loop alone; end-to-end rows include the set-up (our orbital design: path
table + Riccati gains, built into an empty cache folder or read from the disk cache; MuJoCo: parsing the URDF
into an MjModel). Our rows also give the process CPU time, which a loaded machine inflates less. The target is >= 20x real time end to end
(set-up, controller, monitor, plant and the metrics after the run). Each timing is the median of
``repeat`` runs (the machine may be shared), with the load average printed.
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

from pathmotion import defaults
from pathmotion.control import OrbitalDesign, OrbitalGains, PathTable, design_cache
from pathmotion.joint_path import SplineJointPath
from pathmotion.planning.profile import Profile
from pathmotion.robot import load_robot
from pathmotion.simulation import Plant, SimulationSettings, simulate

WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                      [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                      [1.0, 0.1, 0.2, -0.2, 0.4, 1.2],
                      [1.4, -0.2, 0.4, 0.1, 0.9, 1.6]])


CPU = {}  # label -> median process CPU time [s] of the last median_of call with that label


def median_of(fn, repeat, label=None):
    """(median wall-clock time [s], last result); the median process CPU time goes to CPU[label]."""
    times, cpu = [], []
    out = None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    if label:
        CPU[label] = float(np.median(cpu))
    return float(np.median(times)), out


def end_to_end(robot, path, profile, settings, repeat):
    """simulate() with its set-up (path table + orbital design) inside: (cold: the cache folder empty each time,
    warm: a cache hit), median wall-clock seconds each."""
    with tempfile.TemporaryDirectory() as folder:
        os.environ[design_cache.ENV] = folder

        def cold():
            for f in Path(folder).glob("*.npz"):
                f.unlink()
            return simulate(robot, path, profile, "orbital", settings)

        t_cold, _ = median_of(cold, repeat, "cold")
        t_warm, _ = median_of(lambda: simulate(robot, path, profile, "orbital", settings), repeat, "warm")
    os.environ.pop(design_cache.ENV)
    return t_cold, t_warm


def main(repeat: int = 7) -> None:
    load0 = os.getloadavg()[0]
    robot = load_robot("irb140")
    path = SplineJointPath.from_waypoints(WAYPOINTS)
    v, a = 0.9, 2.0
    ta = v * v / (2 * a)
    profile = Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))
    ts = defaults.SAMPLE_TIME
    settings = SimulationSettings(sample_time=ts)
    sampling = (ts, int(settings.realism.delay)) if settings.sampled_design else (None, 0)  # the default design
    t_design, design = median_of(lambda: OrbitalDesign.build(PathTable.from_path(path), profile, OrbitalGains(),
                                                             *sampling), repeat)
    simulate(robot, path, profile, "orbital", settings, design=design)  # warm-up (numba cache, imports)
    t_sim, result = median_of(lambda: simulate(robot, path, profile, "orbital", settings, design=design), repeat,
                              "loop")
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

    t_plant, q_own = median_of(own_plant, repeat)

    model, data = robot.model, robot.model.createData()
    n = robot.n

    def peer():
        x = np.concatenate([q0, qd0])
        for tau in result.tau:
            sol = solve_ivp(lambda _, s: np.concatenate([s[n:], pin.aba(model, data, s[:n], s[n:], tau)]),
                            (0.0, ts), x, method="RK45", rtol=1e-6, atol=1e-9)
            x = sol.y[:, -1]
        return x[:n]

    t_peer, q_peer = median_of(peer, repeat)
    mujoco_rows = mujoco_peer(robot, result, settings, repeat)
    rtf_sim, rtf_plant, rtf_peer = simulated / t_sim, simulated / t_plant, simulated / t_peer
    print(f"load average (1 min) before / after  {load0:.2f} / {os.getloadavg()[0]:.2f} (2 cores)")
    print(f"simulated time                              {simulated:8.3f} s ({len(result.t)} samples of {ts * 1e3:g} ms)")
    print(f"orbital design (table + Riccati), once      {t_design * 1e3:8.1f} ms")
    print(f"closed loop (controller + plant + metrics)  {t_sim * 1e3:8.1f} ms  -> {rtf_sim:6.1f} x real time")
    print(f"plant alone, RK4 x {settings.substeps}, same torques         {t_plant * 1e3:8.1f} ms  -> {rtf_plant:6.1f} x real time")
    print(f"peer: ABA in solve_ivp (RK45), same torques {t_peer * 1e3:8.1f} ms  -> {rtf_peer:6.1f} x real time")
    print(f"ratio closed loop / peer                    {rtf_sim / rtf_peer:8.2f}")
    print(f"ratio plant / peer                          {rtf_plant / rtf_peer:8.2f}")
    print(f"final-state difference own plant vs peer    {np.max(np.abs(q_own - q_peer)):.2e} rad")
    for label, seconds, key in (("end to end, set-up built (cache empty)", t_cold, "cold"),
                                ("end to end, set-up from the disk cache", t_warm, "warm"),
                                ("loop only (design given)", t_sim, "loop")):
        print(f"{label:44s}{seconds * 1e3:8.1f} ms  -> {simulated / seconds:6.1f} x real time "
              f"(CPU {CPU[key] * 1e3:6.1f} ms -> {simulated / CPU[key]:6.1f} x)")
    for label, seconds in mujoco_rows:
        print(f"{label:44s}{seconds * 1e3:8.1f} ms  -> {simulated / seconds:6.1f} x real time")
    print(f"target >= 20x real time end to end (cache empty): {'met' if simulated / t_cold >= 20 else 'NOT met'} "
          f"(wall clock; CPU time {'met' if simulated / CPU['cold'] >= 20 else 'NOT met'})")


def mujoco_peer(robot, result, settings, repeat: int) -> list[tuple[str, float]]:
    """(label, seconds) rows for MuJoCo: the plant alone on the same torques, and MuJoCo + a plain PD
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

    t_replay, _ = median_of(replay, repeat)
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
    t_loop, _ = median_of(lambda: pd_loop(model), repeat)
    t_e2e, _ = median_of(lambda: pd_loop(build_model(robot, timestep=ts / substeps)), repeat)
    return [(f"MuJoCo plant alone, RK4 x {substeps}, same torques", t_replay),
            ("MuJoCo + plain PD, loop only", t_loop),
            ("MuJoCo + plain PD, end to end (URDF parse)", t_e2e)]


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
