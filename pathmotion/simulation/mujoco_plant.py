"""MuJoCo as a second, independent plant: the same URDF, integrated by MuJoCo instead of our RK4.

MuJoCo parses the robot's URDF text itself (its own inertial parsing, fixed-joint fusion and
inertia composition), so agreement with the built-in plant checks Pinocchio's model as well as the
integrator. Before parsing, the URDF is edited, not the compiled model:

* ``<visual>``/``<collision>`` are removed (contacts are off; meshes need not be present);
* ``Realism.inertia_error``: each moving joint's child link (and the links fixed to it) has its
  ``<mass>`` and ``<inertia>`` scaled by the same seeded factor as :func:`.realism.plant_model`;
* the robot's payload and ``Realism``'s unmodelled payload become links fixed to the flange link,
  which MuJoCo fuses into the last moving body (as Pinocchio merges them into the last joint).

After compiling: armature (``dof_armature``) from the limits file, gravity from the robot, viscous
friction as MuJoCo joint damping (``dof_damping``), Coulomb friction as ``dof_frictionloss`` (MuJoCo's
dry-friction constraint: a bounded force, not our smooth F_c tanh(qd / v_c), so the two plants differ
near zero speed), URDF damping/friction overwritten (the built-in plant ignores them too). Contacts,
joint limits, equality constraints and MuJoCo's auto-reset are disabled: the built-in plant has none
of them, and a diverging run must stay visible to the monitor. Sensor quantisation, noise and delay
stay in the loop (:class:`.realism.Sensor`), as for the built-in plant.

The torque is held over a sample (``qfrc_applied``) and the sample is integrated with ``substeps``
MuJoCo steps of dt / substeps, by MuJoCo's RK4 (default: the same order and step as ours, so
the plants differ by round-off and modelling only) or its implicit-in-velocity ``implicitfast``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from enum import Enum
from functools import cached_property
from xml.etree import ElementTree

import numpy as np

from .. import defaults
from ..errors import RobotModelError, SimulationError
from ..robot import Robot
from .saturation import saturate as _saturate
from .stiffness import check_substeps
from .realism import Realism

log = logging.getLogger(__name__)

INSTALL_HINT = 'MuJoCo is not installed; install it with: pip install "pathmotion[mujoco]"'
_PAYLOAD_LINKS = ("pathmotion_payload", "pathmotion_unmodelled_payload")


class MujocoIntegrator(str, Enum):
    """MuJoCo's integrator for the plant: classical RK4, or implicit-in-velocity (first order)."""

    RK4 = "rk4"
    IMPLICITFAST = "implicitfast"


def import_mujoco():
    """The ``mujoco`` module, or SimulationError with the one-line install command."""
    try:
        import mujoco
    except ImportError:
        raise SimulationError(INSTALL_HINT) from None
    return mujoco


def _inertial_link(name: str, mass: float, com, inertia) -> ElementTree.Element:
    """<link> with an <inertial>: mass [kg], com (3,) [m], inertia (3, 3) [kg m^2] about the com."""
    link = ElementTree.Element("link", {"name": name})
    inertial = ElementTree.SubElement(link, "inertial")
    ElementTree.SubElement(inertial, "origin", {"xyz": " ".join(repr(float(c)) for c in com), "rpy": "0 0 0"})
    ElementTree.SubElement(inertial, "mass", {"value": repr(float(mass))})
    i = np.asarray(inertia, float)
    ElementTree.SubElement(inertial, "inertia", {k: repr(float(i[a, b])) for k, (a, b) in (
        ("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)), ("iyy", (1, 1)), ("iyz", (1, 2)), ("izz", (2, 2)))})
    return link


def _scale_inertial(link: ElementTree.Element, scale: float) -> None:
    """Multiply a link's <mass> and <inertia> (about its com, so the com stays) by ``scale``."""
    inertial = link.find("inertial")
    if inertial is None:
        return
    mass, inertia = inertial.find("mass"), inertial.find("inertia")
    if mass is not None:
        mass.set("value", repr(float(mass.get("value", "0")) * scale))
    if inertia is not None:
        for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            inertia.set(key, repr(float(inertia.get(key, "0")) * scale))


def plant_urdf(robot: Robot, realism: Realism = Realism()) -> str:
    """The robot's URDF text as MuJoCo's plant loads it (see the module docstring)."""
    root = ElementTree.fromstring(robot.urdf_text)
    for parent in root.iter():
        for child in [c for c in parent if c.tag in ("visual", "collision")]:
            parent.remove(child)
    links = {link.get("name"): link for link in root.findall("link")}
    joints = root.findall("joint")
    if realism.inertia_error > 0:
        children: dict[str, list] = {}
        for j in joints:
            children.setdefault(j.find("parent").get("link"), []).append(j)
        by_name = {j.get("name"): j for j in joints}
        for name, scale in zip(robot.joint_names, realism.link_scales(robot.n)):
            stack = [by_name[name].find("child").get("link")]
            while stack:  # the child link and every link fixed to it (Pinocchio merges them into one body)
                link = stack.pop()
                _scale_inertial(links[link], float(scale))
                stack += [j.find("child").get("link") for j in children.get(link, []) if j.get("type") == "fixed"]
    if robot.flange_frame not in links:
        raise SimulationError(f"robot {robot.name}: the flange frame '{robot.flange_frame}' is not a <link> of its URDF; "
                              "MuJoCo's plant attaches the payload to a link, name one as the flange")
    payloads = [(robot.payload.mass, robot.payload.com, robot.payload.inertia),
                (realism.payload_mass, realism.payload_com, np.diag(np.asarray(realism.payload_inertia, float)))]
    for name, (mass, com, inertia) in zip(_PAYLOAD_LINKS, payloads):
        if mass > 0:
            root.append(_inertial_link(name, mass, com, inertia))
            joint = ElementTree.SubElement(root, "joint", {"name": f"{name}_fixed", "type": "fixed"})
            ElementTree.SubElement(joint, "parent", {"link": robot.flange_frame})
            ElementTree.SubElement(joint, "child", {"link": name})
            ElementTree.SubElement(joint, "origin", {"xyz": "0 0 0", "rpy": "0 0 0"})
    extension = ElementTree.SubElement(root, "mujoco")
    ElementTree.SubElement(extension, "compiler", {"fusestatic": "true", "discardvisual": "true",
                                                   "balanceinertia": "false", "inertiafromgeom": "false"})
    return ElementTree.tostring(root, encoding="unicode")


def build_model(robot: Robot, realism: Realism = Realism(), timestep: float = defaults.SAMPLE_TIME / defaults.PLANT_SUBSTEPS,
                integrator: MujocoIntegrator = MujocoIntegrator.RK4):
    """A compiled ``mujoco.MjModel`` of the plant; RobotModelError naming the URDF element MuJoCo rejects."""
    mujoco = import_mujoco()
    try:
        model = mujoco.MjModel.from_xml_string(plant_urdf(robot, realism))
    except ValueError as exc:
        text = " ".join(line.strip() for line in str(exc).strip().splitlines()[:2])
        raise RobotModelError(f"URDF of {robot.name} cannot be loaded by MuJoCo: {text}; fix that element of the "
                              "URDF or use plant = \"builtin\"") from None
    names = tuple(model.joint(i).name for i in range(model.njnt))
    if model.nv != robot.n or names != robot.joint_names:
        raise SimulationError(f"MuJoCo reads joints {list(names)} from the URDF of {robot.name}, Pinocchio "
                              f"{list(robot.joint_names)}; the plant needs the same revolute/prismatic chain")
    viscous, coulomb = realism.friction(robot.n)
    model.dof_damping[:] = viscous
    model.dof_frictionloss[:] = coulomb
    model.dof_armature[:] = 0.0 if robot.limits.armature is None else np.asarray(robot.limits.armature, float)
    model.jnt_actfrclimited[:] = 0
    model.opt.gravity[:] = np.asarray(robot.gravity, float)
    _set_timestep(model, timestep)
    model.opt.integrator = {MujocoIntegrator.RK4: mujoco.mjtIntegrator.mjINT_RK4,
                            MujocoIntegrator.IMPLICITFAST: mujoco.mjtIntegrator.mjINT_IMPLICITFAST}[
        MujocoIntegrator(integrator)]
    off = mujoco.mjtDisableBit
    model.opt.disableflags |= (off.mjDSBL_CONTACT | off.mjDSBL_LIMIT | off.mjDSBL_EQUALITY | off.mjDSBL_AUTORESET)
    # recompute the constants derived at compile time: dof_invweight0 (which scales the friction-loss
    # constraint's regularisation) must see the armature, else a light wrist joint's friction nearly vanishes
    mujoco.mj_setConst(model, mujoco.MjData(model))
    return model


def _set_timestep(model, timestep: float) -> None:
    """MuJoCo's step [s], and the friction-loss constraint's time constant at its floor 2 x step (MuJoCo's
    'refsafe' bound): the constraint's reference deceleration -qd / (0.475 timeconst) is then as steep as
    the step allows, so friction loss stays -F_c sign(qd) unless the commanded deceleration exceeds it."""
    model.opt.timestep = float(timestep)
    model.dof_solref[:, 0] = 2.0 * float(timestep)


@dataclass(eq=False)
class MujocoPlant:
    """The arm in MuJoCo, with the built-in :class:`.plant.Plant`'s interface.

    model: ``mujoco.MjModel``; torque_limit (n,) [N m]; viscous (n,) [N m s/rad]; coulomb (n,) [N m];
    integrator: MuJoCo's integrator. ``data`` is this plant's workspace (one run at a time).
    """

    model: object
    torque_limit: np.ndarray
    viscous: np.ndarray
    coulomb: np.ndarray
    integrator: MujocoIntegrator = MujocoIntegrator.RK4

    name = "mujoco"

    @classmethod
    def from_robot(cls, robot: Robot, realism: Realism = Realism(), integrator: MujocoIntegrator = MujocoIntegrator.RK4
                   ) -> "MujocoPlant":
        viscous, coulomb = realism.friction(robot.n)
        model = build_model(robot, realism, integrator=integrator)
        return cls(model, np.asarray(robot.limits.torque, float).copy(), viscous, coulomb, MujocoIntegrator(integrator))

    @cached_property
    def _mujoco(self):
        return import_mujoco()

    @cached_property
    def data(self):
        return self._mujoco.MjData(self.model)

    @property
    def n(self) -> int:
        return int(self.model.nv)

    def reset(self) -> None:
        """Forget the solver's warm start and the applied torque (a fresh run)."""
        self._mujoco.mj_resetData(self.model, self.data)

    def saturate(self, tau: np.ndarray) -> tuple[np.ndarray, bool]:
        """tau clipped to +-torque_limit, and whether any joint was clipped."""
        out = np.empty(len(tau))
        _, clipped = _saturate(np.ascontiguousarray(tau, dtype=float), self.torque_limit, out)
        return out, bool(clipped)

    def _forward(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray | None = None):
        d = self.data
        d.qpos[:], d.qvel[:] = q, qd
        d.qfrc_applied[:] = 0.0 if tau is None else tau
        self._mujoco.mj_forward(self.model, d)
        return d

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M(q) (n, n) [kg m^2], armature included (MuJoCo's mj_fullM)."""
        d = self._forward(q, np.zeros(self.n))
        out = np.empty((self.n, self.n))
        self._mujoco.mj_fullM(self.model, d, out)
        return out

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """C(q, qd) qd + g(q) (n,) [N m] (MuJoCo's qfrc_bias; friction excluded)."""
        return self._forward(q, qd).qfrc_bias.copy()

    def acceleration(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """qdd (n,) [rad/s^2] for the applied torque tau (n,), friction included."""
        return self._forward(q, qd, tau).qacc.copy()

    def step(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray, dt: float, substeps: int) -> tuple[np.ndarray, np.ndarray]:
        """State after ``dt`` seconds of constant torque tau (n,), by ``substeps`` MuJoCo steps of dt / substeps."""
        if substeps < 1:
            raise SimulationError(f"plant sub-steps must be >= 1, got {substeps}")
        m, d = self.model, self.data
        if m.opt.timestep != dt / substeps:
            _set_timestep(m, dt / substeps)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, qd, tau
        self._mujoco.mj_step(m, d, substeps)
        return d.qpos.copy(), d.qvel.copy()

    def substeps_needed(self, q: np.ndarray, dt: float) -> tuple[int, str]:
        """The fewest MuJoCo steps per sample ``dt`` [s] for which explicit RK4 integrates the joint damping
        accurately (h F_v / M_jj <= 1), and why (empty when one does).

        ``implicitfast`` integrates damping implicitly and has no such bound; MuJoCo's friction loss is a
        soft constraint whose time constant follows the step (2 h), so it needs no check.
        """
        if self.integrator is not MujocoIntegrator.RK4 or not np.any(self.viscous > 0):
            return 1, ""
        rate = self.viscous / np.diag(self.mass_matrix(np.asarray(q, float)))
        j = int(np.argmax(rate))
        return (max(1, int(np.ceil(dt * rate[j] - 1e-12))),
                f"joint {self.model.joint(j).name}: damping {self.viscous[j]:.3g} N m s/rad decays in {1.0 / rate[j]:.3g} s")

    def check_step(self, q: np.ndarray, dt: float, substeps: int) -> None:
        """SimulationError when ``substeps`` MuJoCo steps per sample are fewer than :meth:`substeps_needed`."""
        check_substeps(self.substeps_needed(q, dt), dt, substeps, "simulate.realism.viscous_friction of that joint")
