"""The virtual IRC5's motion: EGM's filtering, cascaded servo loops and elastic gearboxes, per axis.

One EGM cycle (``DriveParameters.cycle``) takes the sensor's position reference p and speed reference s
(n,) [rad, rad/s] and, after the transport delay (whole cycles),

    p_f, s_f    first-order low-pass of p, s at ``lowpass_bandwidth``
    v           s_f + K_pc (p_f - r) / cycle, within s_f +- max_speed_deviation   (the servo's speed demand)
    r           the servo's position reference, advanced by v over the cycle

and the servo, every ``rate`` seconds, per axis on the motor (link-side units):

    v_ref = k_v v + Kp (r - q_m);   tau = Kv (v_ref - qd_m) + Kv / Ti int(v_ref - qd_m) + k_t tau_ff
    tau clipped to the motor's torque-speed envelope (the limits file's torque, full up to the knee speed,
    linearly down to torque_at_max_speed at the top speed), tau_ff the rigid inverse dynamics of (r, v, a)
    with the rotors (the controller's own model), Kv = speed_bandwidth x rotor inertia.

The arm: the motor J_m qdd_m = tau - s_g on an elastic axis, s_g = K (q_m - q) + D (qd_m - qd) the gear's
torque, and the links M(q) qdd + h(q, qd) = s_g (elastic axes) or tau (rigid axes, rotor inertia on the
diagonal). The built-in plant integrates motors and links together by classical RK4 with tau held over each
servo period (Pinocchio ABA for the links). The MuJoCo plant (``plant="mujoco"``, simulation's
:class:`~pathmotion.simulation.mujoco_plant.MujocoPlant`: MuJoCo's own reading of the URDF and its RK4) moves
the links: each servo period is split into short coupling steps; over each, MuJoCo moves the links under a held
gear torque (tau on rigid axes), then the motors are integrated by RK4 against the links' motion over the step
(linear between its ends), twice: a predictor under the gear torque of the step's start, a corrector under the
mean of the start's and the predictor's end's. The splitting is second order in the coupling step, which is
chosen so that it spans at most 1/20 rad of the fastest gear mode. The feedback EGM reports is the motor
side q_m (the IRC5 measures motor angles); the TCP follows the link side q.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import ExecutionError
from ..robot import Robot
from ..simulation.plant import PLANT_NAMES, make_plant
from .drive_file import DriveParameters

#: The MuJoCo plant's coupling step spans at most this phase [rad] of the fastest gear mode.
COUPLING_PHASE = 0.05


@dataclass
class ArmState:
    """q, qd: link side (n,); qm, qmd: motor side in link units (n,) [rad, rad/s]."""

    q: np.ndarray
    qd: np.ndarray
    qm: np.ndarray
    qmd: np.ndarray

    @classmethod
    def at_rest(cls, q0: np.ndarray) -> "ArmState":
        q0 = np.asarray(q0, float)
        return cls(q0.copy(), np.zeros_like(q0), q0.copy(), np.zeros_like(q0))


class EgmFilter:
    """EGM's reference handling: transport delay, low-pass, position correction and speed-deviation clamp."""

    def __init__(self, params: DriveParameters, q0: np.ndarray):
        n = len(q0)
        self.dt = params.cycle
        self.alpha = 1.0 - np.exp(-2.0 * np.pi * params.lowpass_bandwidth * params.cycle)
        self.gain = params.position_correction_gain
        self.max_dev = params.max_speed_deviation
        delay = int(round(params.transport_delay / params.cycle))
        start = (np.asarray(q0, float).copy(), np.zeros(n))
        self.fifo = deque([start] * delay, maxlen=delay + 1)
        self.p_f, self.s_f = start[0].copy(), np.zeros(n)
        self.r = start[0].copy()
        self.v = np.zeros(n)

    def step(self, p: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(r at the cycle's start, v, a) (n,) each for this cycle's reference p, s; advances r by v cycle."""
        self.fifo.append((np.asarray(p, float), np.asarray(s, float)))
        p_d, s_d = self.fifo.popleft()
        self.p_f += self.alpha * (p_d - self.p_f)
        self.s_f += self.alpha * (s_d - self.s_f)
        v = self.s_f + self.gain * (self.p_f - self.r) / self.dt
        v = np.clip(v, self.s_f - self.max_dev, self.s_f + self.max_dev)
        a = (v - self.v) / self.dt
        r0 = self.r.copy()
        self.r += v * self.dt
        self.v = v
        return r0, v, a


class VirtualArm:
    """The arm behind a virtual IRC5: EGM filter + servo + (elastic) plant; :meth:`cycle` advances one EGM
    cycle. ``robot``: the controller's model (its armature = rotor inertias, its torque limits = the motors');
    ``plant_robot``: the arm that moves (default the same; a scenario's payload or model error goes here);
    ``plant``: "builtin" (Pinocchio, RK4 of motors and links together) or "mujoco" (MuJoCo moves the links)."""

    def __init__(self, robot: Robot, params: DriveParameters, q0: np.ndarray, plant_robot: Robot | None = None,
                 plant: str = "builtin"):
        n = robot.n
        if params.stiffness.shape != (n,):
            raise ExecutionError(f"drive file has {params.stiffness.size} axes for a {n}-joint robot")
        lim = robot.limits
        self.robot, self.params, self.n = robot, params, n
        self.rotor = np.zeros(n) if lim.armature is None else np.asarray(lim.armature, float).copy()
        self.elastic = params.elastic & (self.rotor > 0)
        links = (plant_robot or robot).model.copy()
        arm = np.array(links.armature, float)
        arm[self.elastic] = 0.0  # the rotor is the motor mass of an elastic axis, not the link's
        links.armature = arm
        self.model, self.data = links, links.createData()
        self.ctrl_model, self.ctrl_data = robot.model, robot.model.createData()
        self.k, self.d = params.stiffness * self.elastic, params.damping * self.elastic
        self.kv = params.speed_bandwidth * np.maximum(self.rotor, 1e-6)
        self.tau_max, self.qd_max = np.asarray(lim.torque, float), np.asarray(lim.velocity, float)
        knee, at_max = params.torque_speed_knee, params.torque_at_max_speed
        self.slope = (1.0 - at_max) / (1.0 - knee)
        self.knee = knee
        self.state = self._held_at(np.asarray(q0, float))
        self.filter = EgmFilter(params, self.state.qm)
        self.integral = np.zeros(n)
        self.substeps = params.substeps()
        self.h = params.cycle / self.substeps
        self.tau = np.zeros(n)
        self.saturated = False
        omega = self._check_modes(q0)
        if plant not in PLANT_NAMES:
            raise ExecutionError(f"plant {plant!r}: choose one of {', '.join(PLANT_NAMES)}")
        self.plant = plant
        self.mujoco = self._mujoco_links(plant_robot or robot) if plant == "mujoco" else None
        self.couplings = max(1, int(np.ceil(self.h * omega / COUPLING_PHASE)))

    def _held_at(self, q0: np.ndarray) -> ArmState:
        """At rest with the link at q0: each elastic gear wound up by its gravity load, K (q_m - q0) = g(q0)."""
        state = ArmState.at_rest(q0)
        if self.elastic.any():
            g = pin.computeGeneralizedGravity(self.model, self.data, q0)
            state.qm = np.where(self.elastic, q0 + g / np.where(self.elastic, self.k, 1.0), q0)
        return state

    def _check_modes(self, q0: np.ndarray) -> float:
        """The fastest gear mode [rad/s] at q0 (0 without elastic axes); refuse a servo period too long for it
        (RK4 needs h omega well below 2.8)."""
        if not self.elastic.any():
            return 0.0
        link = np.diag(pin.crba(self.model, self.data, np.asarray(q0, float)))
        j = self.elastic
        omega = np.sqrt(self.k[j] * (1.0 / self.rotor[j] + 1.0 / np.maximum(link[j], 1e-9)))
        if self.h * omega.max() > 1.0:
            raise ExecutionError(f"drive file: a gear mode of {omega.max() / (2 * np.pi):.0f} Hz is too fast for the "
                                 f"servo period {self.h:g} s; lower servo.rate or the stiffness")
        return float(omega.max())

    def _mujoco_links(self, plant_robot: Robot):
        """simulation's MuJoCo plant of ``plant_robot`` with the rotors on the rigid axes only (an elastic axis's
        rotor is the motor mass, on the other side of the gear)."""
        from ..simulation.mujoco_plant import import_mujoco

        plant = make_plant("mujoco", plant_robot)
        plant.model.dof_armature[self.elastic] = 0.0
        mujoco = import_mujoco()
        mujoco.mj_setConst(plant.model, mujoco.MjData(plant.model))  # the constants that follow the armature
        return plant

    def _coupled(self, tau: np.ndarray, link_tau: np.ndarray, c: float) -> ArmState:
        """The state after ``c`` seconds: MuJoCo moves the links under ``link_tau`` (n,) held, then RK4 moves the
        motors under ``tau`` against the links' motion over the step (linear between its ends)."""
        s, el = self.state, self.elastic
        rotor = np.where(el, self.rotor, 1.0)

        def motor_accel(qm, qmd, q, qd):
            return np.where(el, (tau - self.k * (qm - q) - self.d * (qmd - qd)) / rotor, 0.0)

        q0, qd0, qm, qmd = s.q, s.qd, s.qm, s.qmd
        q1, qd1 = self.mujoco.step(q0, qd0, link_tau, c, 1)
        qmid, qdmid = 0.5 * (q0 + q1), 0.5 * (qd0 + qd1)
        a1 = motor_accel(qm, qmd, q0, qd0)
        v2 = qmd + 0.5 * c * a1
        a2 = motor_accel(qm + 0.5 * c * qmd, v2, qmid, qdmid)
        v3 = qmd + 0.5 * c * a2
        a3 = motor_accel(qm + 0.5 * c * v2, v3, qmid, qdmid)
        v4 = qmd + c * a3
        a4 = motor_accel(qm + c * v3, v4, q1, qd1)
        return ArmState(q1, qd1, np.where(el, qm + c / 6.0 * (qmd + 2 * v2 + 2 * v3 + v4), q1),
                        np.where(el, qmd + c / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4), qd1))

    def _gear(self, s: ArmState) -> np.ndarray:
        """The gears' torque (n,) [N m] in state s (0 on rigid axes)."""
        return self.k * (s.qm - s.q) + self.d * (s.qmd - s.qd)

    def _mujoco_step(self, tau: np.ndarray) -> None:
        """One servo period on the MuJoCo plant in coupling steps, each a predictor (the links under the gear
        torque of the step's start) and a corrector (under the mean of the start's and the predicted end's)."""
        el = self.elastic
        c = self.h / self.couplings
        for _ in range(self.couplings):
            start = self._gear(self.state)
            state = self._coupled(tau, np.where(el, start, tau), c)
            if el.any():  # rigid gears: the links' torque is tau, held; the predictor is exact
                state = self._coupled(tau, np.where(el, 0.5 * (start + self._gear(state)), tau), c)
            self.state = state

    def envelope(self, qmd: np.ndarray) -> np.ndarray:
        """The motor torque limit (n,) [N m] at motor speed qmd (n,)."""
        w = np.abs(qmd) / self.qd_max
        return self.tau_max * np.clip(1.0 - self.slope * np.maximum(w - self.knee, 0.0), 0.0, 1.0)

    def _accel(self, q, qd, qm, qmd, tau):
        el = self.elastic
        gear = self.k * (qm - q) + self.d * (qmd - qd)
        link_tau = np.where(el, gear, tau)
        qdd = pin.aba(self.model, self.data, q, qd, link_tau)
        qmdd = np.where(el, (tau - gear) / np.where(el, self.rotor, 1.0), qdd)
        return qdd, qmdd

    def _rk4(self, tau: np.ndarray) -> None:
        s, h = self.state, self.h
        q, qd, qm, qmd = s.q, s.qd, s.qm, s.qmd
        a1, b1 = self._accel(q, qd, qm, qmd, tau)
        a2, b2 = self._accel(q + 0.5 * h * qd, qd + 0.5 * h * a1, qm + 0.5 * h * qmd, qmd + 0.5 * h * b1, tau)
        v2, w2 = qd + 0.5 * h * a1, qmd + 0.5 * h * b1
        a3, b3 = self._accel(q + 0.5 * h * v2, qd + 0.5 * h * a2, qm + 0.5 * h * w2, qmd + 0.5 * h * b2, tau)
        v3, w3 = qd + 0.5 * h * a2, qmd + 0.5 * h * b2
        a4, b4 = self._accel(q + h * v3, qd + h * a3, qm + h * w3, qmd + h * b3, tau)
        v4, w4 = qd + h * a3, qmd + h * b3
        s.q = q + h / 6.0 * (qd + 2 * v2 + 2 * v3 + v4)
        s.qm = qm + h / 6.0 * (qmd + 2 * w2 + 2 * w3 + w4)
        s.qd = qd + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
        s.qmd = qmd + h / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
        s.qm = np.where(self.elastic, s.qm, s.q)
        s.qmd = np.where(self.elastic, s.qmd, s.qd)

    def cycle(self, p: np.ndarray, s: np.ndarray) -> None:
        """One EGM cycle with the sensor's reference p (n,) [rad] and speed reference s (n,) [rad/s]."""
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(s))):
            raise ExecutionError("EGM reference is not finite")
        r0, v, a = self.filter.step(p, s)
        par = self.params
        tau_ff = pin.rnea(self.ctrl_model, self.ctrl_data, r0, v, a) * par.torque_feedforward
        saturated = False
        for i in range(self.substeps):
            r = r0 + v * (i * self.h)
            st = self.state
            v_ref = par.speed_feedforward * v + par.position_gain * (r - st.qm)
            err = v_ref - st.qmd
            self.integral += err * self.h
            tau = self.kv * (err + self.integral / par.speed_integration_time) + tau_ff
            limit = self.envelope(st.qmd)
            clipped = np.clip(tau, -limit, limit)
            if np.any(clipped != tau):
                saturated = True
                self.integral -= err * self.h  # anti-windup: no integration while the motor is at its limit
            self.tau = clipped
            if self.mujoco is None:
                self._rk4(clipped)
            else:
                self._mujoco_step(clipped)
        self.saturated = saturated
        if not np.all(np.isfinite(self.state.q)):
            raise ExecutionError("the virtual arm's state diverged (a drive parameter makes the loop unstable)")

    @property
    def feedback(self) -> np.ndarray:
        """The joints EGM reports (n,) [rad]: the motor side (the IRC5 measures motor angles)."""
        return self.state.qm.copy()
