"""The robot: a Pinocchio model of an arm with its limits, payload and tool frame.

A :class:`Robot` is an immutable value: ``with_payload``/``with_tool``/``with_limits`` return new
robots. It pickles (by its URDF text and parameters), so it can be shipped to worker processes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import os
import re
from functools import cached_property
from importlib import resources
from xml.etree import ElementTree
from pathlib import Path

import numpy as np
import pinocchio as pin

from .. import defaults
from ..errors import RobotModelError, check_finite
from ..io.files import captured_fd2, read_input
from .limits import JointLimits, limits_from_model, limits_from_toml

TCP_FRAME = "tcp"
#: Payload inertia: an eigenvalue down to -this is rounding of a positive semi-definite matrix [kg m^2].
INERTIA_ROUNDING = 1e-12
#: Payload inertia: an asymmetry max|I - I^T| up to this fraction of max|I| is rounding, and the matrix
#: is symmetrised as (I + I^T)/2 (Pinocchio refuses any asymmetry); beyond it the input is refused [-].
INERTIA_SYMMETRY = 1e-6
#: Tool rotation: max |R^T R - I| allowed [-].
ORTHONORMALITY = 1e-9
#: A URDF joint axis shorter than this has no direction [-].
ZERO_AXIS = 1e-12


@dataclass(frozen=True)
class Payload:
    """Rigid payload attached to the flange.

    mass [kg]; com (3,) [m] in the flange frame; inertia (3, 3) [kg m^2] about the centre of
    mass, in flange-frame axes (default: a point mass).
    """

    mass: float = 0.0
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[tuple[float, ...], ...] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def __post_init__(self):
        check_finite("payload mass", self.mass)
        check_finite("payload com", self.com)
        check_finite("payload inertia", self.inertia)
        if self.mass < 0:
            raise RobotModelError(f"payload mass is {self.mass:g} kg; it must be >= 0")
        if np.shape(self.com) != (3,) or np.shape(self.inertia) != (3, 3):
            raise RobotModelError("payload: com must have 3 values [m] and inertia a 3x3 matrix [kg m^2]")
        inertia = np.asarray(self.inertia, float)
        asym = float(np.max(np.abs(inertia - inertia.T)))
        if asym > INERTIA_SYMMETRY * float(np.max(np.abs(inertia))):
            raise RobotModelError(f"payload inertia must be symmetric positive semi-definite (it is asymmetric by "
                                  f"{asym:.3g} kg m^2); give robot.payload.inertia with I[i][j] = I[j][i]")
        inertia = 0.5 * (inertia + inertia.T)
        object.__setattr__(self, "inertia", tuple(map(tuple, inertia.tolist())))
        if np.min(np.linalg.eigvalsh(inertia)) < -INERTIA_ROUNDING:
            raise RobotModelError("payload inertia must be symmetric positive semi-definite")
        com = np.asarray(self.com, float)
        with np.errstate(over="ignore", invalid="ignore"):
            products = (self.mass * com, self.mass * float(com @ com))
        for value, what in zip(products, ("mass x com", "mass x |com|^2")):
            if not np.all(np.isfinite(value)):
                raise RobotModelError(f"payload {what} overflows (mass {self.mass:g} kg, com {com.tolist()} m); "
                                      "give robot.payload a centre of mass within metres of the flange")


@dataclass(frozen=True)
class Tool:
    """Tool frame (TCP) relative to the flange: translation (3,) [m] and rotation (3, 3)."""

    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[tuple[float, ...], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))

    def __post_init__(self):
        check_finite("tool translation", self.translation)
        check_finite("tool rotation", self.rotation)
        r = np.asarray(self.rotation, float)
        if np.shape(self.translation) != (3,) or r.shape != (3, 3):
            raise RobotModelError("tool: translation must have 3 values [m] and rotation be a 3x3 matrix")
        if not np.allclose(r.T @ r, np.eye(3), atol=ORTHONORMALITY) or np.linalg.det(r) < 0:
            raise RobotModelError("tool rotation is not a proper rotation matrix (R^T R = I, det R = +1)")

    @property
    def se3(self) -> pin.SE3:
        return pin.SE3(np.asarray(self.rotation, float), np.asarray(self.translation, float))


@dataclass(frozen=True, eq=False)
class Robot:
    """An arm: URDF text, limits, payload, tool, and the flange frame they attach to.

    Build with :func:`load_robot`. ``model`` is the Pinocchio model with the payload merged into
    the last link, a ``"tcp"`` frame and, when the limits give one, the drives' armature
    (``model.armature``, reflected rotor inertia [kg m^2]); ``n`` is the number of joints.
    ``locked_joints``: ((name, value [rad or m]), ...) joints of the URDF fixed at a value (e.g.
    gripper fingers); the model is reduced (``pinocchio.buildReducedModel``), so ``n``, the joint
    names and the limits cover only the moving joints.
    """

    name: str
    urdf_text: str
    limits: JointLimits
    flange_frame: str
    payload: Payload = field(default_factory=Payload)
    tool: Tool = field(default_factory=Tool)
    gravity: tuple[float, float, float] = defaults.GRAVITY
    locked_joints: tuple[tuple[str, float], ...] = ()

    @cached_property
    def model(self) -> pin.Model:
        model = reduced_model(_build_model(self.urdf_text, self.name), self.locked_joints, self.name)
        if not model.existFrame(self.flange_frame):
            frames = [f.name for f in model.frames]
            raise RobotModelError(f"robot {self.name}: no frame '{self.flange_frame}' (frames: {frames})")
        fid = model.getFrameId(self.flange_frame)
        frame = model.frames[fid]
        if self.payload.mass > 0:
            lever = frame.placement.act(np.asarray(self.payload.com, float))
            rot = frame.placement.rotation
            inertia = rot @ np.asarray(self.payload.inertia, float) @ rot.T
            model.inertias[frame.parentJoint] += pin.Inertia(self.payload.mass, lever, inertia)
        model.addFrame(pin.Frame(TCP_FRAME, frame.parentJoint, fid, frame.placement * self.tool.se3,
                                 pin.FrameType.OP_FRAME))
        model.gravity.linear = np.asarray(self.gravity, float)
        if self.limits.armature is not None:  # reflected rotor inertias (crba, rnea and aba include them)
            model.armature = np.asarray(self.limits.armature, float).copy()
        return model

    @cached_property
    def data(self) -> pin.Data:
        """Scratch data of this process (not shared between threads)."""
        return self.model.createData()

    @cached_property
    def opw_detection(self) -> tuple:
        """(OPWGeometry, "") when the arm has the OPW structure (closed-form IK), else (None, reason).

        Use :func:`pathmotion.robot.ik.opw_geometry`; cached per robot (recomputed after unpickling).
        """
        from .opw import detect_opw

        try:
            geo = detect_opw(self.model, self.tcp_frame_id, self.model.getFrameId(self.flange_frame),
                             self.limits.lower, self.limits.upper)
        except RobotModelError as exc:
            return None, str(exc)
        return geo, ""

    @property
    def n(self) -> int:
        return self.model.nv

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(self.model.names[1:])  # cached: Pinocchio's name list costs ~0.1 ms per read

    @property
    def tcp_frame_id(self) -> int:
        return self.model.getFrameId(TCP_FRAME)

    def frame_id(self, frame: str | int | None) -> int:
        """Frame index of a frame name (None: the TCP)."""
        if frame is None:
            return self.tcp_frame_id
        if isinstance(frame, (int, np.integer)):
            return int(frame)
        if not self.model.existFrame(frame):
            raise RobotModelError(f"robot {self.name}: no frame '{frame}'")
        return self.model.getFrameId(frame)

    def serial_chain(self, frame_id: int):
        """:func:`~.serial_batch.chain_of` of the model and frame ``frame_id`` (a Chain or None), built once per frame
        (every batched Jacobian and acceleration bias asks for it; reading it from the model costs ~0.1 ms)."""
        chains = self._serial_chains
        if frame_id not in chains:
            from .serial_batch import chain_of

            chains[frame_id] = chain_of(self.model, frame_id)
        return chains[frame_id]

    @cached_property
    def _serial_chains(self) -> dict:
        return {}

    def with_payload(self, payload: Payload) -> "Robot":
        return _replace(self, payload=payload)

    def with_tool(self, tool: Tool) -> "Robot":
        return _replace(self, tool=tool)

    def with_limits(self, limits: JointLimits) -> "Robot":
        if limits.names != self.limits.names:
            raise RobotModelError(f"limits are for joints {list(limits.names)}, robot has {list(self.joint_names)}")
        return _replace(self, limits=limits)

    def __getstate__(self):
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, n={self.n}, payload={self.payload.mass:g} kg)"


def _replace(robot: Robot, **changes) -> Robot:
    kwargs = {k: getattr(robot, k) for k in robot.__dataclass_fields__}
    kwargs.update(changes)
    return Robot(**kwargs)


def _check_urdf_size(urdf_text: str, path: Path) -> None:
    """RobotModelError when the URDF has more <link> or <joint> elements than defaults.MAX_URDF_LINKS,
    counted on the text before any parser builds a tree of them."""
    for tag in ("link", "joint"):
        count = len(re.findall(rf"<{tag}[\s/>]", urdf_text))
        if count > defaults.MAX_URDF_LINKS:
            raise RobotModelError(f"URDF file {path} has {count:,} <{tag}> elements, more than "
                                  f"{defaults.MAX_URDF_LINKS:,} (defaults.MAX_URDF_LINKS); give an arm's URDF")


def _build_model(urdf_text: str, where: str) -> pin.Model:
    try:  # urdfdom prints its own "Error:" lines on the C-level stderr: keep them for the message only
        with captured_fd2() as parser_lines:
            model = pin.buildModelFromXML(urdf_text)
    except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with parser text
        said = [ln for ln in parser_lines if ln.lower().startswith("error")]
        detail = said[0] if said else (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        detail = " ".join(re.sub(r"^error:\s*", "", detail, flags=re.I).split())
        raise RobotModelError(f"URDF of {where} cannot be parsed: {detail}") from None
    if model.nq != model.nv:
        raise RobotModelError(
            f"URDF of {where}: only revolute/prismatic chains are supported (nq={model.nq}, nv={model.nv})"
        )
    if model.nv == 0:
        raise RobotModelError(f"URDF of {where} has no movable joints")
    return model


#: A locked joint's value may exceed its URDF range by this much (rounding of a copied limit) [rad or m].
_LOCK_SLACK = 1e-12


def reduced_model(model: pin.Model, locked: tuple[tuple[str, float], ...], where: str) -> pin.Model:
    """``model`` with the joints ``locked`` ((name, value), ...) fixed at their values; RobotModelError
    naming a joint that does not exist or a value outside the joint's URDF range."""
    if not locked:
        return model
    names = list(model.names[1:])
    q = pin.neutral(model)
    ids = []
    for name, value in locked:
        if name not in names:
            raise RobotModelError(f"robot {where}: locked joint '{name}' is not a moving joint of the URDF {names}")
        jid = model.getJointId(name)
        joint = model.joints[jid]
        if joint.nq != 1:
            raise RobotModelError(f"robot {where}: locked joint '{name}' has {joint.nq} coordinates; only "
                                  "revolute and prismatic joints can be locked")
        lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
        v = float(value)
        bounded = np.isfinite(lo) and np.isfinite(hi) and lo < hi
        if not np.isfinite(v) or (bounded and not lo - _LOCK_SLACK <= v <= hi + _LOCK_SLACK):
            raise RobotModelError(f"robot {where}: locked joint '{name}' = {value!r} is outside its range "
                                  f"[{lo:g}, {hi:g}] (rad or m); give a value inside it")
        q[joint.idx_q] = v
        ids.append(jid)
    if len(ids) == len(names):
        raise RobotModelError(f"robot {where}: every joint is locked; leave at least one joint free")
    return pin.buildReducedModel(model, ids, q)


def _check_urdf_limits(urdf_text: str, where: str, limits_given: bool) -> str:
    """URDF text with a placeholder <limit/> in every revolute/prismatic joint that has none (the URDF
    parser needs one) when limits come from elsewhere; RobotModelError naming those joints when not."""
    try:
        root = ElementTree.fromstring(urdf_text)
    except ElementTree.ParseError as exc:
        raise RobotModelError(f"URDF of {where} is not well-formed XML: {exc}") from None
    _check_urdf_tree(root, where)
    bare = [j for j in root.iter("joint") if j.get("type") in ("revolute", "prismatic") and j.find("limit") is None]
    if not bare:
        return urdf_text
    names = [j.get("name") for j in bare]
    if not limits_given:
        raise RobotModelError(
            f"URDF of {where}: joints {names} have no <limit> tag and no limits file was given; add "
            "<limit lower upper velocity effort> to each joint or give a limits file"
        )
    for j in bare:
        ElementTree.SubElement(j, "limit", {"lower": "0", "upper": "0", "effort": "0", "velocity": "0"})
    return ElementTree.tostring(root, encoding="unicode")


_MOVING = ("revolute", "prismatic", "continuous")


def _check_urdf_tree(root, where: str) -> None:
    """RobotModelError naming the element when a URDF is not one tree of links joined by joints: no
    <robot> element, duplicate names, a joint naming a missing link, a link with two parents or a
    closed loop, links not connected to the root (a missing joint), a zero joint axis, a negative mass."""
    if root.tag != "robot":
        raise RobotModelError(f"URDF of {where}: the top element is <{root.tag}>, not <robot>")
    links = [link.get("name") for link in root.findall("link")]
    for kind, names in (("link", links), ("joint", [j.get("name") for j in root.findall("joint")])):
        dup = sorted({n for n in names if names.count(n) > 1}, key=str)
        if dup:
            raise RobotModelError(f"URDF of {where}: {kind} name(s) {dup} used more than once; names must be unique")
    known = set(links)
    parent_of: dict[str, str] = {}
    children: dict[str, list[str]] = {}
    for j in root.findall("joint"):
        name = j.get("name")
        ends = {}
        for end in ("parent", "child"):
            el = j.find(end)
            ends[end] = None if el is None else el.get("link")
            if ends[end] not in known:
                raise RobotModelError(f"URDF of {where} cannot be parsed: joint '{name}' names {end} link {ends[end]!r}, which is not "
                                      f"a <link> of the file {sorted(known, key=str)}; add the link or fix the name")
        child = ends["child"]
        if child in parent_of:
            raise RobotModelError(f"URDF of {where}: link '{child}' is the child of two joints ('{parent_of[child]}' "
                                  f"and '{name}'): a closed loop; URDF describes trees, remove one of the joints")
        parent_of[child] = name
        children.setdefault(ends["parent"], []).append(child)
        axis = j.find("axis")
        if j.get("type") in _MOVING and axis is not None:
            try:
                xyz = np.array([float(v) for v in axis.get("xyz", "1 0 0").split()])
            except ValueError:
                xyz = np.array([np.nan])
            if xyz.shape != (3,) or not np.all(np.isfinite(xyz)) or np.linalg.norm(xyz) < ZERO_AXIS:
                raise RobotModelError(f"URDF of {where}: joint '{name}' has axis xyz = {axis.get('xyz')!r}; give a "
                                      "non-zero finite direction of 3 numbers")
    roots = [link for link in links if link not in parent_of]
    if not roots:
        raise RobotModelError(f"URDF of {where}: every link has a parent joint, so the joints form a closed loop; "
                              "URDF describes trees, remove the joint that closes the loop")
    if len(roots) > 1:
        raise RobotModelError(f"URDF of {where}: links {roots} are not connected (each is a root: no joint has it as "
                              "child); a joint is missing, add it or remove the unconnected links")
    seen, todo = {roots[0]}, [roots[0]]
    while todo:
        for c in children.get(todo.pop(), []):
            if c not in seen:
                seen.add(c)
                todo.append(c)
    stray = [link for link in links if link not in seen]
    if stray:
        raise RobotModelError(f"URDF of {where}: links {stray} form a closed loop not connected to the root link "
                              f"'{roots[0]}'; URDF describes trees, remove the joint that closes the loop")
    for link in root.findall("link"):
        mass = link.find("inertial/mass")
        if mass is not None:
            try:
                m = float(mass.get("value", "nan"))
            except ValueError:
                m = float("nan")
            if not (np.isfinite(m) and m >= 0):
                raise RobotModelError(f"URDF of {where}: link '{link.get('name')}' has mass {mass.get('value')!r}; "
                                      "give a finite mass >= 0 kg")


BUILTIN_ROBOTS = {"irb140": ("irb140.urdf", "irb140_limits.toml", "IRB140")}


def builtin_robot_names() -> list[str]:
    return sorted(BUILTIN_ROBOTS)


def load_robot(
    name_or_urdf: str | Path = "irb140",
    limits: str | Path | JointLimits | None = None,
    *,
    payload: Payload | None = None,
    tool: Tool | None = None,
    flange_frame: str | None = None,
    locked_joints: dict[str, float] | None = None,
) -> Robot:
    """Load a built-in robot by name (``"irb140"``) or any arm from a URDF file.

    ``limits``: a limits TOML file or a :class:`JointLimits`; when None, a built-in robot uses its
    shipped limits file and a URDF its own ``<limit>`` tags (missing ones are an error naming them).
    ``flange_frame``: frame the payload and tool attach to (default: the last frame of the URDF).
    ``locked_joints``: {joint name: value [rad or m]} joints fixed at a value (e.g. gripper fingers);
    a limits file may list them too (their entries are ignored).
    """
    key = str(name_or_urdf).lower()
    if key in BUILTIN_ROBOTS:
        urdf_file, limits_file, display = BUILTIN_ROBOTS[key]
        base = resources.files("pathmotion.robot") / "data"
        urdf_text = (base / urdf_file).read_text()
        default_limits = base / limits_file
        name = display
    else:
        path = Path(name_or_urdf)
        plain = "\0" not in str(path) and len(os.fsencode(str(path))) <= defaults.MAX_PATH_BYTES
        if plain and (not os.path.lexists(path) or os.path.isdir(path)):  # else read_input names the problem
            raise RobotModelError(
                f"robot '{name_or_urdf}' is neither a built-in robot ({', '.join(builtin_robot_names())}) "
                "nor an existing URDF file"
            )
        urdf_text = read_input(path, "urdf")
        _check_urdf_size(urdf_text, path)
        default_limits = None
        name = path.stem
    urdf_text = _check_urdf_limits(urdf_text, name, limits_given=limits is not None or default_limits is not None)
    locked = tuple((str(k), float(v)) for k, v in (locked_joints or {}).items())
    model = reduced_model(_build_model(urdf_text, name), locked, name)
    names = tuple(model.names[1:])
    ignore = tuple(k for k, _ in locked)
    if isinstance(limits, JointLimits):
        lim = limits
    elif limits is not None:
        lim = limits_from_toml(limits, names, ignore=ignore)
    elif default_limits is not None:
        lim = limits_from_toml(Path(str(default_limits)), names, ignore=ignore)
    else:
        lim = limits_from_model(model, where=f"URDF {name_or_urdf}")
    if lim.names != names:
        raise RobotModelError(f"limits are for joints {list(lim.names)}, the URDF has {list(names)}")
    if flange_frame is None:
        flange_frame = model.frames[len(model.frames) - 1].name
    return Robot(name=name, urdf_text=urdf_text, limits=lim, flange_frame=flange_frame,
                 payload=payload or Payload(), tool=tool or Tool(), locked_joints=locked)
