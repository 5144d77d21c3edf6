"""The IRB140 acceleration estimates from the torque and armature estimates, and their check against ABB's
figures: the 57 m/s^2 TCP acceleration (IRB 140T, nominal load, gravity included) and the foundation loads in
operation (Mz +-250 N m, Mxy +-700 N m).

    PYTHONPATH=$PWD python benchmarks/irb140_acceleration_estimates.py [--configs 1000]

Prints, for seeded random configurations of the good workspace with the rated 6 kg payload 0.1 m beyond
the flange: (1) per joint, the largest single-axis acceleration from rest that the torque estimates allow
(every joint's |M[:, i] qdd_i + g| <= torque limit, the better of the two directions), its percentiles and
the rule the limits file uses (90th percentile rounded to 5 rad/s^2); (2) the largest TCP acceleration
(any direction of five, wrist orientation free) that the torques allow, with and without the armature and
the acceleration box, as a linear program per configuration; (3) the foundation moments (tilting Mxy about the
base origin, turning Mz) that each single-axis acceleration of the limits file causes from rest, against ABB's.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
import pinocchio as pin
from scipy.optimize import linprog

from pathmotion.robot import Payload, gravity, jacobian, load_robot, mass_matrix

RATED = Payload(mass=6.0, com=(0.0, 0.0, 0.1))  #: ABB's rated payload, centre of gravity 0.1 m beyond the flange
#: the sampled box of "typical" configurations [deg]: reach about 0.35-0.85 m, wrist within +-90 deg
LOWER_DEG = np.array([-90.0, -40.0, -110.0, -90.0, -90.0, -180.0])
UPPER_DEG = np.array([90.0, 80.0, 20.0, 90.0, 90.0, 180.0])
PERCENTILE = 90.0  #: the estimate: this percentile of the torque-allowed acceleration ...
ROUND_TO = 5.0  #: ... rounded to this [rad/s^2]
ABB_TCP_ACCELERATION = 57.0  #: [m/s^2], ABB product specification, IRB 140T, nominal load, gravity included
ABB_FOUNDATION_MXY = 700.0  #: [N m], ABB product specification: tilting moment on the foundation in operation
ABB_FOUNDATION_MZ = 250.0  #: [N m], ABB product specification: turning moment on the foundation in operation
DIRECTIONS = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [0, 0, -1.0]])
GRAVITY = np.array([0.0, 0.0, -9.81])


def configurations(n: int, seed: int = 0) -> np.ndarray:
    """n seeded random configurations (n, 6) [rad] in the typical box."""
    u = np.random.default_rng(seed).random((n, 6))
    return np.radians(LOWER_DEG + (UPPER_DEG - LOWER_DEG) * u)


def single_axis_acceleration(M: np.ndarray, g: np.ndarray, torque: np.ndarray) -> np.ndarray:
    """(6,) [rad/s^2]: per joint i, the largest |qdd_i| from rest with the other joints held, such that every
    joint's torque M[:, i] qdd_i + g stays within +-torque; the better of the two directions."""
    out = np.zeros(len(g))
    for i in range(len(g)):
        best = 0.0
        for sign in (1.0, -1.0):
            c = sign * M[:, i]
            with np.errstate(divide="ignore"):
                bound = np.where(c > 0, (torque - g) / c, np.where(c < 0, (-torque - g) / c, np.inf))
            best = max(best, float(np.min(bound)))
        out[i] = best
    return out


def tcp_acceleration(M, g, Jv, torque, direction, box=None) -> float:
    """Largest s [m/s^2] with Jv qdd = s * direction from rest, |M qdd + g| <= torque and |qdd| <= box."""
    n = len(g)
    A_ub = np.vstack([np.hstack([M, np.zeros((n, 1))]), np.hstack([-M, np.zeros((n, 1))])])
    b_ub = np.concatenate([torque - g, torque + g])
    bounds = [(-b, b) for b in box] if box is not None else [(None, None)] * n
    res = linprog(np.r_[np.zeros(n), -1.0], A_ub=A_ub, b_ub=b_ub, A_eq=np.hstack([Jv, -direction[:, None]]),
                  b_eq=np.zeros(3), bounds=bounds + [(0, None)], method="highs")
    return float(res.x[-1]) if res.status == 0 else 0.0


def torque_allowed(robot, Q: np.ndarray) -> np.ndarray:
    """(N, 6) [rad/s^2]: single_axis_acceleration at each configuration of Q."""
    M, g = mass_matrix(robot, Q), gravity(robot, Q)
    return np.array([single_axis_acceleration(M[k], g[k], robot.limits.torque) for k in range(len(Q))])


def estimates(robot, Q: np.ndarray) -> np.ndarray:
    """(6,) [rad/s^2]: the limits file's rule, the PERCENTILE of torque_allowed rounded to ROUND_TO."""
    return ROUND_TO * np.round(np.percentile(torque_allowed(robot, Q), PERCENTILE, axis=0) / ROUND_TO)


def foundation_moments(robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> tuple[float, float]:
    """(|Mxy|, |Mz|) [N m]: the moment the arm exerts on its foundation about the base origin (axis 1 meets the
    mounting plane there), from the spatial force transmitted through joint 1 (recursive Newton-Euler)."""
    model = robot.model
    data = model.createData()
    pin.rnea(model, data, q, qd, qdd)
    moment = data.oMi[1].act(data.f[1]).angular  # about the world origin, world axes
    return float(np.hypot(moment[0], moment[1])), float(abs(moment[2]))


def foundation_table(robot, Q: np.ndarray) -> np.ndarray:
    """(N, 6, 2) [N m]: per configuration and joint i, the foundation (|Mxy|, |Mz|) when joint i accelerates from
    rest as fast as the limits file allows (its acceleration, cut to what every joint's torque allows; the worse
    direction), the others held."""
    out = np.zeros((len(Q), len(robot.limits.names), 2))
    zero = np.zeros(Q.shape[1])
    M, g, torque = mass_matrix(robot, Q), gravity(robot, Q), robot.limits.torque
    for k, q in enumerate(Q):
        for i, a in enumerate(robot.limits.acceleration):
            loads = []
            for sign in (1.0, -1.0):
                c = sign * M[k][:, i]
                with np.errstate(divide="ignore"):
                    bound = np.where(c > 0, (torque - g[k]) / c, np.where(c < 0, (-torque - g[k]) / c, np.inf))
                qdd = np.zeros_like(zero)
                qdd[i] = sign * max(0.0, min(a, float(np.min(bound))))
                loads.append(foundation_moments(robot, q, zero, qdd))
            out[k, i] = np.max(loads, axis=0)
    return out


def tcp_table(robot, Q: np.ndarray, box=None) -> tuple[np.ndarray, np.ndarray]:
    """Per configuration: the largest TCP acceleration over DIRECTIONS [m/s^2] and the largest specific
    force |a - g| [m/s^2] (ABB's "gravity included")."""
    M, g, J = mass_matrix(robot, Q), gravity(robot, Q), jacobian(robot, Q)
    acc, force = [], []
    for k in range(len(Q)):
        s = np.array([tcp_acceleration(M[k], g[k], J[k][:3], robot.limits.torque, d, box) for d in DIRECTIONS])
        acc.append(s.max())
        force.append(max(np.linalg.norm(si * d - GRAVITY) for si, d in zip(s, DIRECTIONS)))
    return np.array(acc), np.array(force)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--configs", type=int, default=1000)
    ap.add_argument("--tcp-configs", type=int, default=150)
    a = ap.parse_args()
    robot = load_robot("irb140", payload=RATED)
    Q = configurations(a.configs)
    A = torque_allowed(robot, Q)
    pct = np.percentile(A, [10, 50, 90], axis=0)
    print(f"torque-allowed single-axis acceleration [rad/s^2], 6 kg, {a.configs} configurations")
    print("| joint | p10 | median | p90 | estimate (p90 to 5) | limits file |")
    print("|---|---|---|---|---|---|")
    est = estimates(robot, Q)
    for i, name in enumerate(robot.limits.names):
        print(f"| {name} | {pct[0, i]:.1f} | {pct[1, i]:.1f} | {pct[2, i]:.1f} | {est[i]:.0f} | "
              f"{robot.limits.acceleration[i]:g} |")
    Qt = Q[: a.tcp_configs]
    def armature(scale):
        return robot.with_limits(dataclasses.replace(robot.limits, armature=scale * robot.limits.armature))

    print(f"\nlargest TCP acceleration [m/s^2] over {a.tcp_configs} configurations (p10 / median / p90 / max); "
          f"ABB: {ABB_TCP_ACCELERATION:g}")
    for label, r, box in (("torques + armature", robot, None), ("torques + armature + acceleration box", robot,
                          robot.limits.acceleration),
                          ("torques, half the armature", armature(0.5), None),
                          ("torques, a quarter of the armature", armature(0.25), None),
                          ("torques, no armature", armature(0.0), None),
                          ("torques + armature, 1 kg at the flange", load_robot("irb140", payload=Payload(1.0)), None)):
        acc, force = tcp_table(r, Qt, box)
        fmt = " / ".join(f"{v:.1f}" for v in np.percentile(acc, [10, 50, 90, 100]))
        fmt_f = " / ".join(f"{v:.1f}" for v in np.percentile(force, [10, 50, 90, 100]))
        print(f"  {label}: acceleration {fmt}; specific force |a - g| {fmt_f}")

    loads = foundation_table(robot, Qt)
    print(f"\nfoundation moments [N m] from each single-axis acceleration the limits file allows, from rest, 6 kg, "
          f"{a.tcp_configs} configurations (max); ABB in operation: Mxy {ABB_FOUNDATION_MXY:g}, Mz {ABB_FOUNDATION_MZ:g}")
    print("| joint | Mxy p90 | Mxy max | Mz max |")
    print("|---|---|---|---|")
    for i, name in enumerate(robot.limits.names):
        print(f"| {name} | {np.percentile(loads[:, i, 0], 90):.0f} | {loads[:, i, 0].max():.0f} | "
              f"{loads[:, i, 1].max():.0f} |")


if __name__ == "__main__":
    main()
