"""Real-time factor of the closed-loop simulation (simulated seconds per wall-clock second).

One closed-loop run of the IRB140 (6 joints) along a joint spline at the 4 ms controller sample time,
orbital controller, plant = RK4 with defaults.PLANT_SUBSTEPS sub-steps per sample. The peer, measured
in the same run: the same applied torque profile (zero-order hold per sample) integrated by a plain
loop that calls Pinocchio's ABA inside scipy's solve_ivp (RK45, rtol 1e-6, one call per sample, as a
straightforward closed-loop simulation would do it). Both are printed with their ratio; the target is
>= 20x real time for the closed loop (controller, monitor, plant and the metrics after the run). Each timing
is the median of ``repeat`` runs (the machine may be shared), with the load average printed.
Run: python benchmarks/bench_simulation.py [repeat]
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

from pathmotion import defaults
from pathmotion.control import OrbitalDesign, PathTable
from pathmotion.joint_path import SplineJointPath
from pathmotion.planning.profile import Profile
from pathmotion.robot import load_robot
from pathmotion.simulation import Plant, SimulationSettings, simulate

WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                      [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                      [1.0, 0.1, 0.2, -0.2, 0.4, 1.2],
                      [1.4, -0.2, 0.4, 0.1, 0.9, 1.6]])


def median_of(fn, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def main(repeat: int = 7) -> None:
    load0 = os.getloadavg()[0]
    robot = load_robot("irb140")
    path = SplineJointPath.from_waypoints(WAYPOINTS)
    v, a = 0.9, 2.0
    ta = v * v / (2 * a)
    profile = Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))
    ts = defaults.SAMPLE_TIME
    settings = SimulationSettings(sample_time=ts)
    t_design, design = median_of(lambda: OrbitalDesign.build(PathTable.from_path(path), profile), repeat)
    simulate(robot, path, profile, "orbital", settings, design=design)  # warm-up (numba cache, imports)
    t_sim, result = median_of(lambda: simulate(robot, path, profile, "orbital", settings, design=design), repeat)
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
    print(f"target >= 20x real time for the closed loop: {'met' if rtf_sim >= 20 else 'NOT met'}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
