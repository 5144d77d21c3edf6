"""ABB RAPID programs as input: parse a module into plain data, write it as a scenario.

What is read (keywords are case-insensitive; ``!`` starts a comment; a statement runs to its ``;``
over any number of lines):

* ``CONST`` / ``PERS`` / ``VAR`` declarations of ``robtarget`` ([[x, y, z] mm, [q1..q4],
  [cf1, cf4, cf6, cfx], [eax_a..eax_f]]), ``tooldata``, ``wobjdata``, ``speeddata``,
  ``zonedata``, ``jointtarget`` ([[robax_a..robax_f] deg, [extax_a..extax_f]]) and ``num``, wherever they
  are; other data types are ignored (data, not motion).
* ``PROC main`` (or the only procedure with moves) run as the controller reads it: calls of
  procedures without parameters inlined (recursion is an error), ``FOR`` loops with constant bounds
  unrolled, ``WaitTime`` a dwell after the last move, ``ConfL`` / ``ConfJ`` ``\\On`` / ``\\Off``.
* ``MoveL`` / ``MoveJ`` / ``MoveC`` with targets given by name, inline, as ``Offs(p, dx, dy, dz)`` or
  ``RelTool(p, dx, dy, dz)`` (num expressions of numbers and num names); speeds ``v5`` ... ``v7000``,
  custom speeddata (its ``v_tcp``), ``\\V:=`` [mm/s] and ``\\T:=`` [s]; zones ``fine``, ``z0`` ...
  ``z200`` (ABB's table of pzone_tcp, pzone_ori and zone_ori), custom zonedata and ``\\Z:=``; the tool
  (``tframe``, and ``tload`` as the payload) and ``\\WObj:=`` (``uframe`` and ``oframe``); ``\\Conc``
  is ignored with a note.
* ``MoveAbsJ`` to a jointtarget (by name or inline; speed, zone, tool and ``\\WObj`` as for ``MoveJ``): a
  joint move to its axes, degrees to radians. The external axes are not read (a value other than 9E9 is
  noted). Its TCP pose, which the zones, lengths and the next move's start need, is ``flange(joints)``
  times the tool frame: :func:`parse_rapid` takes the robot's flange kinematics as a function (this layer
  does not know the robot). The work object does not move a jointtarget.

Frames: a robtarget is the TCP pose in the object frame, so the TCP pose in the robot base frame is
T_base_tcp = T_uframe T_oframe T_target (quaternions [q1, q2, q3, q4] = [w, x, y, z]). The robot base
is the world frame (no ``baseframe``). Positions are converted from mm to m.

What it is not: a RAPID interpreter. Other control flow, calls with arguments, assignments at run
time, I/O and every other motion instruction (``SearchL``, ``TriggL``, ``SingArea``, ...)
are listed as unsupported with their line numbers: an error unless skipped.

The scenario (see docs/program.md for the mapping):

* Each move is a segment carrying its target's orientation (``quaternion``) and its program data
  (``[path.segments.program]``: line, target, instruction, speed, zone, robconf, ConfL state): ``MoveL``
  a line, ``MoveC`` an arc, ``MoveJ`` a joint move to the target's pose on its robconf, ``MoveAbsJ`` a
  joint move to ``end`` [rad]; each ``WaitTime`` a dwell segment. The first move's target is the start
  pose (``[path.start_pose]``), or with ``MoveAbsJ`` the start configuration (``start_configuration``).
* A zone is the sphere around the target where ABB's corner path starts; as on the controller it is
  reduced to half the distance to the neighbouring programmed positions. Its orientation zone is
  written as the segment's ``orientation_zone``. A fine point (and a move followed by a WaitTime) is
  a stop.

:func:`rapid_estimate_s` is the program's duration on an ideal constant-speed controller with zone
blending: a lower bound of what the real controller achieves (it ignores acceleration).
"""

from __future__ import annotations

import ast
import dataclasses
import logging
import math
import operator
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scipy.spatial.transform import Rotation

from .. import defaults
from ..errors import ScenarioError

log = logging.getLogger(__name__)

#: ABB's predefined speeddata: v_tcp [mm/s].
SPEEDS_MM_S = {f"v{v}": float(v) for v in (5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600,
                                           800, 1000, 1500, 2000, 2500, 3000, 4000, 5000, 6000, 7000)}
#: ABB's predefined zonedata: (pzone_tcp [mm], pzone_ori [mm], zone_ori [deg]); fine = stop point, 0.
ZONEDATA = {"fine": (0.0, 0.0, 0.0), "z0": (0.3, 0.3, 0.03), "z1": (1.0, 1.0, 0.1), "z5": (5.0, 8.0, 0.8),
            "z10": (10.0, 15.0, 1.5), "z15": (15.0, 23.0, 2.3), "z20": (20.0, 30.0, 3.0), "z30": (30.0, 45.0, 4.5),
            "z40": (40.0, 60.0, 6.0), "z50": (50.0, 75.0, 7.5), "z60": (60.0, 90.0, 9.0),
            "z80": (80.0, 120.0, 12.0), "z100": (100.0, 150.0, 15.0), "z150": (150.0, 225.0, 23.0),
            "z200": (200.0, 300.0, 30.0)}
#: ABB's predefined zonedata: pzone_tcp [mm].
ZONES_MM = {name: z[0] for name, z in ZONEDATA.items()}
#: Statements that neither move the robot nor change its motion or timing.
_HARMLESS = {"tpwrite", "tperase", "errwrite", "tpshow"}
#: Block keywords: their lines carry no ``;``.
_BLOCKS = {"module", "endmodule", "proc", "endproc", "func", "endfunc", "trap", "endtrap", "if", "else",
           "elseif", "endif", "for", "endfor", "while", "endwhile", "test", "case", "default", "endtest",
           "error", "undo", "backward", "local", "task"}
_MOVE_ARGS = {"movel": ("to", "speed", "zone", "tool"), "movej": ("to", "speed", "zone", "tool"),
              "movec": ("via", "to", "speed", "zone", "tool"), "moveabsj": ("to", "speed", "zone", "tool")}
#: A jointtarget's external axis value that means "no axis" (ABB's 9E9); smaller ones are noted as not read.
_NO_EXTAX = 8.9e9
_OPTIONAL = {"v", "t", "z", "wobj", "conc", "inpos", "id", "noeoffs"}  # \NoEOffs: external axes, not read
_SAME_ROTATION = 1e-6  # largest element difference of two rotation matrices taken as equal [-]
_GIMBAL_LOCK = 1e-12  # cos(pitch) below which roll and yaw are one turn (all put in roll) [-]
_COLLINEAR = 1e-9  # |ab x ac| / (longest side)^2 below which three circle points are a line [-]
_STRAIGHT = 1e-9  # corner turn angle below which a zone is taken as a straight join [rad]
_RIGHT_ANGLE_MARGIN = 1e-15  # keeps tan(half turn) finite at a full reversal [rad]
#: The blends an import can write at each zone: the zone's symmetric G2 blend, or the fastest within its deviation.
BLEND_TYPES = ("g2", "optimal")
_ZONE_ROUNDING = 1e-12  # a zone reduced by less than this is not reported as reduced [m]
_HALF_TURN_MARGIN = 1e-6  # consecutive targets closer than this to a half turn apart have no turn direction [rad]
_ZERO_QUATERNION = 1e-6  # a quaternion shorter than this has no direction to normalize to [-]
#: Most moves an import unrolls (procedure calls and FOR loops), against a loop that never ends in practice.
MAX_PROGRAM_MOVES = 200_000
#: Arithmetic a num expression may use (``Offs(p, i * 50, 0, 0)``; numbers and num names).
_ARITH = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
          ast.USub: operator.neg, ast.UAdd: operator.pos}


# ------------------------------------------------------------------------------------ plain data
@dataclass(frozen=True)
class Frame:
    """A rigid transform: ``translation`` (3,) [m] and ``rotation`` (3, 3)."""

    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __matmul__(self, other: "Frame") -> "Frame":
        return Frame(self.translation + self.rotation @ other.translation, self.rotation @ other.rotation)


@dataclass(frozen=True)
class RapidTool:
    """A tooldata: ``frame`` (TCP in the flange frame) and its load (mass [kg], com (3,) [m],
    inertia (3, 3) [kg m^2] about the com in flange axes)."""

    name: str
    frame: Frame
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))


@dataclass(frozen=True)
class RapidMove:
    """One Move instruction: ``kind`` "L", "J", "C" or "AbsJ"; ``point`` (3,) TCP target in the base frame [m];
    ``rotation`` (3, 3) TCP orientation in the base frame; ``via`` (3,) MoveC circle point [m];
    ``speed`` v_tcp [m/s] (None when ``time`` [s] is given by ``\\T``); ``zone`` programmed zone
    radius [m] (0 = fine point); ``zone_ori`` the zone's pzone_ori [m] and ``zone_ori_angle`` its
    zone_ori [rad]; ``target`` the target as written; ``quaternion`` (4,) the target's [q1..q4] as
    written (normalized); ``robconf`` (cf1, cf4, cf6, cfx); ``conf`` True when ConfL / ConfJ \\On
    holds the robconf for this move; ``dwell`` the WaitTime after it [s], ``dwell_line`` the line of the first;
    ``joints`` (6,) [rad] the jointtarget's axes of a MoveAbsJ (None otherwise)."""

    kind: str
    line: int
    text: str
    point: np.ndarray
    rotation: np.ndarray
    via: np.ndarray | None
    speed: float | None
    time: float | None
    zone: float
    zone_name: str
    tool: str
    target: str = ""
    quaternion: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    robconf: tuple[int, int, int, int] | None = None
    conf: bool = True
    zone_ori: float = 0.0
    zone_ori_angle: float = 0.0
    dwell: float = 0.0
    dwell_line: int = 0
    joints: np.ndarray | None = None

    @property
    def instruction(self) -> str:
        """The RAPID instruction: MoveL, MoveJ, MoveC or MoveAbsJ."""
        return "Move" + self.kind

    @property
    def joint(self) -> bool:
        """A joint-space move (MoveJ, MoveAbsJ)."""
        return self.kind in ("J", "AbsJ")


@dataclass(frozen=True)
class RapidProgram:
    """A parsed RAPID module: the moves of its main procedure, the one tool they use and the
    statements that were not understood, as (line, text), and what the import changed or ignored
    (``remarks``, one sentence each: a quaternion normalized, a \\Conc ignored, a repeated target dropped)."""

    source: str
    module: str
    procedure: str
    moves: tuple[RapidMove, ...]
    tool: RapidTool
    unsupported: tuple[tuple[int, str], ...]
    remarks: tuple[str, ...] = ()


# ------------------------------------------------------------------------------------- helpers
def unit_quaternion(q, where: str = "quaternion", remarks: list | None = None) -> np.ndarray:
    """ABB quaternion [q1, q2, q3, q4] = [w, x, y, z] normalized (4,); a norm more than
    defaults.QUATERNION_NORM_TOLERANCE from 1 is logged and added to ``remarks``; ScenarioError for a
    zero, non-finite or wrongly sized one."""
    try:
        v = np.array([float(c) for c in q], float)
    except (TypeError, ValueError):
        raise ScenarioError(f"{where}: quaternion {q!r} must be four numbers [q1, q2, q3, q4] = [w, x, y, z]") from None
    n = float(np.linalg.norm(v)) if v.shape == (4,) else float("nan")
    if not (math.isfinite(n) and n > _ZERO_QUATERNION):
        raise ScenarioError(f"{where}: quaternion {list(q)} is not a rotation (four finite numbers, not all 0); "
                            "give a unit quaternion [q1, q2, q3, q4] = [w, x, y, z]")
    if abs(n - 1.0) > defaults.QUATERNION_NORM_TOLERANCE:
        msg = f"{where}: quaternion {list(q)} has norm {n:.6g}, not 1; normalized to unit length"
        log.warning(msg)
        if remarks is not None:
            remarks.append(msg)
    return v / n


def quaternion_matrix(q, where: str = "quaternion", remarks: list | None = None) -> np.ndarray:
    """Rotation matrix (3, 3) of an ABB quaternion [q1, q2, q3, q4] = [w, x, y, z], normalized by
    :func:`unit_quaternion` (which reports a norm off 1)."""
    w, x, y, z = unit_quaternion(q, where, remarks)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def matrix_rpy(r: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] with R = Rz(yaw) Ry(pitch) Rx(roll), the scenario's tool convention."""
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    if math.hypot(r[0, 0], r[1, 0]) < _GIMBAL_LOCK:  # gimbal lock: put the whole turn in roll
        return math.atan2(-r[1, 2], r[1, 1]), pitch, 0.0
    return math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])


def _strip_comment(line: str) -> str:
    inside = False
    for i, ch in enumerate(line):
        if ch == '"':
            inside = not inside
        elif ch == "!" and not inside:
            return line[:i]
    return line


def _split_top(text: str, sep: str = ",") -> list[str]:
    """Split at ``sep`` outside brackets, parentheses and strings."""
    parts, depth, inside, cur = [], 0, False, []
    for ch in text:
        if ch == '"':
            inside = not inside
        elif not inside and ch in "[(":
            depth += 1
        elif not inside and ch in "])":
            depth -= 1
        if ch == sep and depth == 0 and not inside:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    return [p.strip() for p in parts]


def _statements(text: str) -> list[tuple[int, str]]:
    """(first line number, statement text without ``;``), block keyword lines as statements of their own."""
    out, buf, start, header = [], "", 0, False
    for lineno, raw in enumerate(text.splitlines(), 1):
        code = _strip_comment(raw).strip()
        if code.startswith("%%%"):
            header = not header
            continue
        if header or not code:
            continue
        if not buf.strip() and code.split(None, 1)[0].split("(")[0].lower() in _BLOCKS and not re.match(
                r"(?i)(local|task)\s+(const|pers|var)\b", code):
            out.append((lineno, code.rstrip(";").strip()))
            continue
        if not buf.strip():
            start = lineno
        pieces = _split_top(buf + " " + code, ";")
        for piece in pieces[:-1]:
            out.append((start, piece))
            start = lineno
        buf = pieces[-1]
    if buf:
        out.append((start, buf))
    return out


# ------------------------------------------------------------------------------------ the parser
class _Parser:
    """State of one parse: declared data, the tool and work object frames, the moves."""

    def __init__(self, where: str, flange=None):
        self.where = where
        self.flange = flange  # joints (6,) [rad] -> (position (3,) [m], rotation (3, 3)) of the flange, or None
        self.data: dict[str, tuple[str, object, int]] = {}  # name (lower) -> (type, value, line)
        self.module = ""
        self.procs: dict[str, list[tuple[int, str]]] = {}  # name -> its statements (line, text)
        self.params: dict[str, bool] = {}  # procedure name (lower) -> it takes parameters
        self.names: dict[str, str] = {}  # procedure name (lower) -> as declared
        self.unsupported: dict[int, str] = {}  # line -> what was skipped there
        self.remarks: list[str] = []
        self.proc = ""
        self.moves: list[RapidMove] = []
        self.conf = {"l": True, "j": True}  # ConfL / ConfJ \On (the controller's default)

    def fail(self, line: int, msg: str):
        raise ScenarioError(f"{self.where}:{line}: {msg}")

    # --- values -------------------------------------------------------------------------------
    def value(self, text: str, line: int):
        """A literal: number, TRUE/FALSE, string, a [..] aggregate (nested lists) or a declared name."""
        t = text.strip()
        if t.startswith("["):
            if not t.endswith("]"):
                self.fail(line, f"unbalanced brackets in {t[:60]!r}")
            inner = t[1:-1].strip()
            return [self.value(p, line) for p in _split_top(inner)] if inner else []
        if t.startswith('"') and t.endswith('"'):
            return t[1:-1]
        if t.upper() in ("TRUE", "FALSE"):
            return t.upper() == "TRUE"
        try:
            return float(t)
        except ValueError:
            pass
        if t.startswith("-") and t[1:].strip().isidentifier():
            return -self.number(t[1:].strip(), line)
        key = t.lower()
        if key in self.data:
            return self.data[key][1]
        self.fail(line, f"cannot read the value {t[:60]!r}: give a number, a [..] aggregate or a declared name "
                        "(expressions are not evaluated)")

    def number(self, text: str, line: int) -> float:
        """A num: a literal, a num name or arithmetic (+ - * /) of them."""
        t = text.strip()
        if re.fullmatch(r"[\w.\s+\-*/()]+", t) and not re.fullmatch(r"-?\s*[\w.]+", t):
            return self.arithmetic(t, line)
        v = self.value(t, line)
        if not isinstance(v, float):
            self.fail(line, f"expected a number, got {t[:40]!r}")
        return v

    def arithmetic(self, text: str, line: int) -> float:
        """The value of a num expression of numbers, num names, + - * / and parentheses."""
        def ev(node):
            if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
                return float(node.value)
            if isinstance(node, ast.Name):
                return self.number(node.id, line)
            if isinstance(node, ast.BinOp) and type(node.op) in _ARITH:
                return _ARITH[type(node.op)](ev(node.left), ev(node.right))
            if isinstance(node, ast.UnaryOp) and type(node.op) in _ARITH:
                return _ARITH[type(node.op)](ev(node.operand))
            raise ValueError
        try:
            return float(ev(ast.parse(text, mode="eval").body))
        except (SyntaxError, ValueError, ZeroDivisionError):
            self.fail(line, f"cannot evaluate {text[:60]!r}: num expressions may use numbers, num names, + - * / "
                            "and parentheses")

    def typed(self, text: str, kind: str, line: int):
        """A value of RAPID type ``kind``: a literal, or the name of a declaration of that type."""
        t = text.strip()
        key = t.lower()
        if key in self.data and not t.startswith("["):
            dtype, value, _ = self.data[key]
            if dtype != kind:
                self.fail(line, f"{t} is a {dtype}, expected a {kind}")
            return value
        return self.value(t, line)

    # --- declarations ---------------------------------------------------------------------------
    def declaration(self, line: int, m: re.Match) -> None:
        dtype, name, dims, init = m.group(2).lower(), m.group(3), m.group(4), m.group(5)
        if dims:
            self.unsupported[self.proc].append((line, f"array declaration {name}{dims} (arrays are not read)"))
            return
        if init is None:
            return  # declared without a value: only an error if a move uses it
        if dtype in ("robtarget", "tooldata", "wobjdata", "speeddata", "zonedata", "jointtarget", "num"):
            self.data[name.lower()] = (dtype, self.value(init, line), line)

    # --- frames ---------------------------------------------------------------------------------
    def pose(self, value, line: int, what: str) -> Frame:
        try:
            trans, quat = value[0], value[1]
            p = np.array([float(v) for v in trans], float) / 1000.0
            if p.shape != (3,):
                raise ValueError
            return Frame(p, quaternion_matrix(quat, f"{self.where}:{line}: {what}", self.remarks))
        except (TypeError, ValueError, IndexError):
            self.fail(line, f"{what}: expected a pose [[x, y, z], [q1, q2, q3, q4]] (mm), got {str(value)[:80]}")

    def tool(self, name: str, line: int) -> RapidTool:
        if name.lower() == "tool0":
            return RapidTool("tool0", Frame())
        if name.lower() not in self.data:
            self.fail(line, f"tool {name} is not declared with a value; declare PERS tooldata {name} := [...]")
        v = self.typed(name, "tooldata", line)
        try:
            robhold, tframe, load = v[0], v[1], v[2]
        except (TypeError, IndexError):
            self.fail(line, f"tooldata {name}: expected [robhold, tframe, tload]")
        if robhold is not True:
            self.fail(line, f"tooldata {name}: a stationary tool (robhold FALSE) is not supported; the robot must "
                            "hold the tool")
        frame = self.pose(tframe, line, f"tooldata {name} tframe")
        try:
            mass = float(load[0])
            com = np.array([float(c) for c in load[1]]) / 1000.0
            aom = quaternion_matrix(load[2], f"{self.where}:{line}: tooldata {name} tload.aom")
            inertia = aom @ np.diag([float(load[3]), float(load[4]), float(load[5])]) @ aom.T
        except (TypeError, ValueError, IndexError):
            self.fail(line, f"tooldata {name}: expected tload [mass, [cx, cy, cz], [q1..q4], ix, iy, iz]")
        return RapidTool(name, frame, max(mass, 0.0), com, inertia)

    def wobj(self, name: str, line: int) -> Frame:
        if name.lower() == "wobj0":
            return Frame()
        if name.lower() not in self.data:
            self.fail(line, f"work object {name} is not declared with a value; declare PERS wobjdata {name} := [...]")
        v = self.typed(name, "wobjdata", line)
        try:
            robhold, ufprog, ufmec, uframe, oframe = v[:5]
        except (TypeError, ValueError):
            self.fail(line, f"wobjdata {name}: expected [robhold, ufprog, ufmec, uframe, oframe]")
        if robhold is True or ufprog is False or ufmec:
            self.fail(line, f"wobjdata {name}: a robot-held or moving work object is not supported; use robhold "
                            "FALSE, ufprog TRUE and ufmec \"\"")
        return self.pose(uframe, line, f"wobjdata {name} uframe") @ self.pose(oframe, line, f"wobjdata {name} oframe")

    def target(self, text: str, line: int) -> Frame:
        """A robtarget expression (name, aggregate, Offs(...), RelTool(...)) as a pose in its object frame."""
        return self.robtarget(text, line)[0]

    def robtarget(self, text: str, line: int) -> tuple[Frame, np.ndarray, tuple[int, int, int, int] | None]:
        """(pose in its object frame, quaternion (4,) as written (normalized), robconf or None when the aggregate
        has none) of a robtarget expression."""
        t = text.strip()
        m = re.fullmatch(r"(?is)(offs|reltool)\s*\((.*)\)", t)
        if m:
            _, quat, conf = self.robtarget(_split_top(m.group(2))[0], line)
            return self.offset(t, line), quat, conf
        value = self.target_value(t, line)
        frame = self.pose(value, line, f"robtarget {t[:40]}")
        quat = unit_quaternion(value[1], f"{self.where}:{line}: robtarget {t[:40]}")
        if len(value) < 3:
            return frame, quat, None
        try:
            conf = tuple(int(round(float(c))) for c in value[2])
            if len(conf) != 4:
                raise ValueError
        except (TypeError, ValueError, IndexError):
            self.fail(line, f"robtarget {t[:40]}: robconf must be [cf1, cf4, cf6, cfx], got {str(value[2:3])[:60]}")
        return frame, quat, conf

    def offset(self, text: str, line: int) -> Frame:
        """The pose of an Offs(...) / RelTool(...) expression, or of a plain target."""
        t = text.strip()
        m = re.fullmatch(r"(?is)(offs|reltool)\s*\((.*)\)", t)
        if m:
            args = _split_top(m.group(2))
            if any(a.startswith("\\") or "\\" in a for a in args) or len(args) != 4:
                self.fail(line, f"{m.group(1)}(...) with rotations or {len(args)} arguments is not supported; use "
                                f"{m.group(1)}(p, dx, dy, dz) in mm")
            base = self.offset(args[0], line)
            d = np.array([self.number(a, line) for a in args[1:]]) / 1000.0
            shift = d if m.group(1).lower() == "offs" else base.rotation @ d
            return Frame(base.translation + shift, base.rotation)
        return self.pose(self.target_value(t, line), line, f"robtarget {t[:40]}")

    def target_value(self, t: str, line: int):
        """The robtarget aggregate of a name or a literal."""
        if t.lower() in self.data and self.data[t.lower()][0] != "robtarget":
            self.fail(line, f"{t} is a {self.data[t.lower()][0]}, not a robtarget")
        if not t.startswith("[") and t.lower() not in self.data:
            self.fail(line, f"robtarget {t!r} is not declared with a value; declare CONST robtarget {t} := [...] "
                            "(run-time assignments are not evaluated)")
        value = self.value(t, line)
        if not isinstance(value, list) or len(value) < 2:
            self.fail(line, f"robtarget {t[:40]}: expected [[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx], "
                            f"[eax_a, ...]], got {str(value)[:80]}")
        return value

    # --- speed and zone -------------------------------------------------------------------------
    def speed(self, text: str, opts: dict, line: int) -> tuple[float | None, float | None]:
        """(v_tcp [m/s] or None, \\T time [s] or None)."""
        if "t" in opts:
            time = self.number(opts["t"], line)
            if time <= 0:
                self.fail(line, f"\\T:={opts['t']} must be a positive time [s]")
            return None, time
        if "v" in opts:
            v = self.number(opts["v"], line)
        elif text.strip().lower() in SPEEDS_MM_S and text.strip().lower() not in self.data:
            v = SPEEDS_MM_S[text.strip().lower()]
        else:
            sd = self.typed(text, "speeddata", line) if text.strip().lower() in self.data or "[" in text else None
            if not isinstance(sd, list) or not sd or not isinstance(sd[0], float):
                self.fail(line, f"speed {text.strip()!r}: give v5 ... v7000, a speeddata [v_tcp, v_ori, v_leax, "
                                "v_reax] or \\V:= (vmax and other robot-dependent speeds are not known here)")
            v = sd[0]
        if v <= 0:
            self.fail(line, f"speed {text.strip()!r}: v_tcp = {v:g} mm/s must be positive")
        return v / 1000.0, None

    def zone(self, text: str, opts: dict, line: int) -> tuple[float, str, float, float]:
        """(zone radius [m], its name, pzone_ori [m], zone_ori [rad]); 0 for fine. pzone_ori is at least
        the zone radius (the controller raises a smaller one to it)."""
        name = text.strip()
        if name.lower() in ZONEDATA and name.lower() not in self.data:
            z, z_ori, a_ori = ZONEDATA[name.lower()]
        else:
            zd = self.typed(name, "zonedata", line) if name.lower() in self.data or "[" in name else None
            if not isinstance(zd, list) or len(zd) < 2 or not all(isinstance(v, float) for v in zd[1:]):
                self.fail(line, f"zone {name!r}: give fine, z0 ... z200 or a zonedata [finep, pzone_tcp, pzone_ori, "
                                "pzone_eax, zone_ori, zone_leax, zone_reax]")
            fine = zd[0] is True
            z = 0.0 if fine else zd[1]
            z_ori = 0.0 if fine or len(zd) < 3 else zd[2]
            a_ori = 0.0 if fine or len(zd) < 5 else zd[4]
        if "z" in opts:
            z = self.number(opts["z"], line)
            name = f"{name}\\Z:={z:g}"
        if z < 0 or z_ori < 0 or a_ori < 0:
            self.fail(line, f"zone {name!r}: zone sizes must not be negative")
        return z / 1000.0, name, max(z, z_ori) / 1000.0, math.radians(a_ori)

    # --- statements -----------------------------------------------------------------------------
    def move(self, line: int, kind: str, args_text: str, text: str) -> RapidMove:
        names = _MOVE_ARGS[kind]
        opts: dict[str, str] = {}
        mains: list[str] = []
        for arg in _split_top(args_text):
            head, *tails = arg.split("\\")
            for tail in tails:
                key, _, val = tail.partition(":=")
                key = key.strip().lower()
                if key not in _OPTIONAL:
                    self.fail(line, f"optional argument \\{key} of {kind} is not supported (supported: "
                                    "\\V, \\T, \\Z, \\WObj, \\Conc, \\Inpos, \\ID, \\NoEOffs); remove it")
                opts[key] = val.strip()
            if head.strip():
                mains.append(head.strip())
        if len(mains) != len(names):
            self.fail(line, f"{kind} needs {len(names)} arguments ({', '.join(names)}), got {len(mains)}: {text[:80]}")
        a = dict(zip(names, mains))
        tool = self.tool(a["tool"], line)
        obj = self.wobj(opts["wobj"], line) if opts.get("wobj") else Frame()
        joints = self.jointtarget(a["to"], line) if kind == "moveabsj" else None
        if joints is None:
            frame, quat, robconf = self.robtarget(a["to"], line)
            tcp = obj @ frame
        else:  # the work object does not move a jointtarget
            tcp, robconf = self.flange_pose(joints, line) @ tool.frame, None
            quat = Rotation.from_matrix(tcp.rotation).as_quat()[[3, 0, 1, 2]]
        via = (obj @ self.target(a["via"], line)).translation if "via" in a else None
        speed, time = self.speed(a["speed"], opts, line)
        zone, zone_name, zone_ori, zone_angle = self.zone(a["zone"], opts, line)
        if "conc" in opts:
            self.remarks.append(f"line {line}: \\Conc ignored (on the controller it lets the next statements run "
                                "while the robot moves; the motion is the same)")
        letter = kind[-1].lower()
        return RapidMove("AbsJ" if joints is not None else letter.upper(), line, " ".join(text.split()),
                         tcp.translation, tcp.rotation, via, speed, time, zone, zone_name, tool.name,
                         target=_target_name(a["to"]), quaternion=quat, robconf=robconf,
                         conf=self.conf["j" if letter == "j" else "l"], zone_ori=zone_ori, zone_ori_angle=zone_angle,
                         joints=joints)

    def jointtarget(self, text: str, line: int) -> np.ndarray:
        """The robot axes (6,) [rad] of a jointtarget (a name or an aggregate [[robax deg x 6], [extax x 6]])."""
        t = text.strip()
        if not t.startswith("[") and t.lower() not in self.data:
            self.fail(line, f"jointtarget {t!r} is not declared with a value; declare CONST jointtarget {t} := "
                            "[[a1, ..., a6], [9E9, ...]] (run-time assignments are not evaluated)")
        value = self.typed(t, "jointtarget", line)
        try:
            robax = np.array([float(v) for v in value[0]], float)
            extax = [float(v) for v in value[1]] if len(value) > 1 else []
            if robax.shape != (6,) or not np.all(np.isfinite(robax)):
                raise ValueError
        except (TypeError, ValueError, IndexError):
            self.fail(line, f"jointtarget {t[:40]}: expected [[robax_a, ..., robax_f] (6 finite angles, deg), "
                            f"[extax_a, ..., extax_f]], got {str(value)[:80]}")
        if any(abs(e) < _NO_EXTAX for e in extax):
            self.remarks.append(f"line {line}: the external axes of jointtarget {t[:40]} are not read (one robot, no "
                                "external axes)")
        return np.radians(robax)

    def flange_pose(self, joints: np.ndarray, line: int) -> Frame:
        """The flange pose in the base frame at ``joints`` (6,) [rad], from the robot's kinematics."""
        if self.flange is None:
            self.fail(line, "MoveAbsJ needs the robot's kinematics to know where the TCP is; read the program with "
                            "parse_rapid(..., flange=api.rapid_flange(robot)) (pathmotion import-rapid does)")
        position, rotation = self.flange(joints)
        return Frame(np.asarray(position, float), np.asarray(rotation, float))

    def statement(self, line: int, text: str) -> None:
        """Collect one statement: declarations are read now, procedure bodies are run by :meth:`run`."""
        word = re.match(r"[A-Za-z_]\w*", text)
        head = word.group(0).lower() if word else ""
        decl = re.fullmatch(r"(?is)(?:(?:local|task)\s+)?(const|pers|var)\s+(\w+)\s+(\w+)\s*(\{[^}]*\})?"
                            r"\s*(?::=\s*(.*))?", text)
        header = re.match(r"(?is)(local\s+)?proc\s+(\w+)\s*(\((.*)\))?", text)
        if decl:
            self.declaration(line, decl)
        elif head == "module":
            self.module = text.split()[1].split("(")[0] if len(text.split()) > 1 else ""
        elif head in ("proc", "local") and header:
            self.proc = header.group(2)
            self.procs.setdefault(self.proc, [])
            self.names[self.proc.lower()] = self.proc
            self.params[self.proc.lower()] = bool((header.group(4) or "").strip())
        elif head == "endproc":
            self.proc = ""
        elif head == "endmodule" or head in _HARMLESS:
            pass
        elif self.proc:
            self.procs[self.proc].append((line, text))
        else:
            self.skip(line, text)

    def skip(self, line: int, text: str, why: str = "") -> None:
        head = (re.match(r"[A-Za-z_]\w*", text) or [""])[0].lower()
        why = why or (" (control flow is not followed)" if head in _BLOCKS else "")
        self.unsupported.setdefault(line, " ".join(text.split())[:80] + why)

    # --- running a procedure ----------------------------------------------------------------------
    def run(self, body: list[tuple[int, str]], stack: tuple[str, ...]) -> None:
        """Run the statements ``body`` of the procedure chain ``stack`` (outermost first): moves appended
        to self.moves, procedure calls inlined, FOR loops unrolled, WaitTime and ConfL / ConfJ applied."""
        i = 0
        while i < len(body):
            line, text = body[i]
            head = (re.match(r"[A-Za-z_]\w*", text) or [""])[0].lower()
            if head == "for":
                end = _block_end(body, i, "for", "endfor")
                if end is None:
                    self.fail(line, "FOR without its ENDFOR")
                self.loop(line, text, body[i + 1:end], stack)
                i = end + 1
                continue
            self.execute(line, text, head, stack)
            i += 1

    def execute(self, line: int, text: str, head: str, stack: tuple[str, ...]) -> None:
        rest = text[len(head):].strip()
        if head in _MOVE_ARGS:
            if len(self.moves) >= MAX_PROGRAM_MOVES:
                self.fail(line, f"the program unrolls to more than {MAX_PROGRAM_MOVES} moves; shorten its loops")
            self.moves.append(self.move(line, head, text[len(head):], text))
        elif head == "waittime":
            self.wait(line, rest)
        elif head in ("confl", "confj"):
            switch = rest.replace(" ", "").lower()
            if switch not in ("\\on", "\\off"):
                self.fail(line, f"{head}: give \\On or \\Off")
            self.conf[head[-1]] = switch == "\\on"
        elif head in self.names and not rest:
            self.call(line, head, stack)
        elif head in self.names:
            self.skip(line, text, " (procedure calls with arguments are not followed)")
        else:
            self.skip(line, text)

    def call(self, line: int, name: str, stack: tuple[str, ...]) -> None:
        proc = self.names[name]
        if proc.lower() in (s.lower() for s in stack):
            chain = " -> ".join(stack + (proc,))
            self.fail(line, f"procedure {proc} calls itself ({chain}); recursion is not unrolled, write the repeats "
                            "as a FOR loop")
        if self.params[name]:
            self.fail(line, f"procedure {proc} takes parameters; only procedures without parameters are inlined")
        self.run(self.procs[proc], stack + (proc,))

    def loop(self, line: int, text: str, body: list[tuple[int, str]], stack: tuple[str, ...]) -> None:
        """Unroll ``FOR v FROM a TO b [STEP s] DO`` with constant a, b, s."""
        m = re.fullmatch(r"(?is)for\s+(\w+)\s+from\s+(.+?)\s+to\s+(.+?)(?:\s+step\s+(.+?))?\s+do", text.strip())
        if not m:
            self.fail(line, "FOR: expected FOR v FROM a TO b [STEP s] DO")
        var = m.group(1).lower()
        lo, hi = self.number(m.group(2), line), self.number(m.group(3), line)
        step = self.number(m.group(4), line) if m.group(4) else (1.0 if hi >= lo else -1.0)
        if step == 0:
            self.fail(line, "FOR: STEP 0 never ends; give a non-zero step")
        count = max(int(math.floor((hi - lo) / step + 1e-9)) + 1, 0)
        if count > MAX_PROGRAM_MOVES:
            self.fail(line, f"FOR runs {count} times, more than {MAX_PROGRAM_MOVES}; shorten the loop")
        saved = self.data.get(var)
        for k in range(count):
            self.data[var] = ("num", lo + k * step, line)
            self.run(body, stack)
        if saved is None:
            self.data.pop(var, None)
        else:
            self.data[var] = saved

    def wait(self, line: int, rest: str) -> None:
        """WaitTime [\\InPos,] t: a dwell of t [s] at rest after the last move."""
        args = [a for a in _split_top(rest) if a and not a.startswith("\\")]
        if len(args) != 1:
            self.fail(line, "WaitTime: expected WaitTime [\\InPos,] time")
        t = self.number(args[0], line)
        if t < 0:
            self.fail(line, f"WaitTime {t:g}: the time must not be negative")
        if not self.moves:
            self.remarks.append(f"line {line}: WaitTime {t:g} s before the first move is not part of the path")
            return
        last = self.moves[-1]
        self.moves[-1] = dataclasses.replace(last, dwell=last.dwell + t, dwell_line=last.dwell_line or line)


def _target_name(text: str) -> str:
    """A target as moves.csv names it: as written, an inline aggregate by its position ("inline [x, y, z]")."""
    t = " ".join(text.split())
    if t.startswith("["):
        return "inline " + _split_top(t[1:-1])[0]
    return t


def _block_end(body: list[tuple[int, str]], start: int, open_word: str, close_word: str) -> int | None:
    """Index of the ``close_word`` statement matching the ``open_word`` one at ``start``, or None."""
    depth = 0
    for k in range(start, len(body)):
        head = (re.match(r"[A-Za-z_]\w*", body[k][1]) or [""])[0].lower()
        depth += (head == open_word) - (head == close_word)
        if depth == 0:
            return k
    return None


def _drop_repeats(moves: list[RapidMove], source: str, remarks: list[str]) -> list[RapidMove]:
    """The moves without those that repeat the previous target's pose (a zero-length move, noted); ScenarioError
    for one that only turns the tool (a reorientation in place has no path length)."""
    out = moves[:1]
    for mv in moves[1:]:
        prev = out[-1]
        if mv.kind != "C" and float(np.linalg.norm(mv.point - prev.point)) < defaults.MIN_SEGMENT_LENGTH:
            turns = np.max(np.abs(mv.rotation - prev.rotation)) > _SAME_ROTATION
            if mv.joints is not None and not turns:  # the same pose on other axes (a branch, a turn of axis 6)
                turns = prev.joints is None or np.max(np.abs(mv.joints - prev.joints)) > _SAME_ROTATION
            if turns and mv.joint:  # a joint move turning the tool in place is a motion
                out.append(mv)
                continue
            if turns:
                raise ScenarioError(f"{source}:{mv.line}: {mv.instruction} to {mv.target} only turns the tool (its "
                                    f"position is that of line {prev.line}); a reorientation in place has no path "
                                    "length: move the TCP as well, or remove the move")
            remarks.append(f"line {mv.line}: {mv.instruction} to {mv.target} repeats the pose of line {prev.line} (a "
                           "zero-length move); dropped")
            if mv.dwell or mv.zone == 0.0:
                out[-1] = dataclasses.replace(prev, dwell=prev.dwell + mv.dwell, zone=min(prev.zone, mv.zone),
                                              dwell_line=prev.dwell_line or mv.dwell_line)
            continue
        out.append(mv)
    return out


def parse_rapid(text: str, source: str = "program.mod", flange=None) -> RapidProgram:
    """Parse RAPID module text (``source`` names it in errors: "file:line: what; what to change").

    Runs ``PROC main`` (or the only procedure with moves): procedure calls without arguments are
    inlined, FOR loops unrolled. ``flange``: joints (6,) [rad] -> (position (3,) [m], rotation (3, 3)) of
    the robot's flange in its base frame, needed by ``MoveAbsJ`` only. ScenarioError if there are fewer
    than two moves, if the moves use more than one tool, or on a value it cannot read."""
    p = _Parser(source, flange)
    for line, stmt in _statements(text):
        p.statement(line, stmt)
    with_moves = [name for name, body in p.procs.items()
                  if any((re.match(r"[A-Za-z_]\w*", t) or [""])[0].lower() in _MOVE_ARGS for _, t in body)]
    main = next((name for name in p.procs if name.lower() == "main"), None)
    if main is None and len(with_moves) > 1:
        raise ScenarioError(f"{source}: procedures {', '.join(with_moves)} all have moves and there is no PROC main; "
                            "the import reads PROC main or the only procedure with moves")
    proc = main or (with_moves[0] if with_moves else "")
    if proc:
        p.run(p.procs[proc], (proc,))
    moves = tuple(_drop_repeats(p.moves, source, p.remarks))
    if len(moves) < 2:
        raise ScenarioError(f"{source}: {'PROC ' + proc if proc else 'the module'} has {len(moves)} "
                            "MoveL/MoveJ/MoveC/MoveAbsJ instructions; a path needs at least two (the first target is the start point)")
    tools = sorted({m.tool for m in moves}, key=str.lower)
    if len({t.lower() for t in tools}) > 1:
        raise ScenarioError(f"{source}: the moves use tools {', '.join(tools)}; a scenario has one tool: use one "
                            "tooldata in every move")
    tool = p.tool(moves[0].tool, moves[0].line)
    return RapidProgram(source, p.module, proc, moves, tool, tuple(sorted(p.unsupported.items())),
                        tuple(dict.fromkeys(p.remarks)))


def read_rapid(path: str | Path, flange=None) -> RapidProgram:
    """Read and parse a RAPID module file (see :func:`parse_rapid`; ``flange`` for MoveAbsJ)."""
    from .files import read_input_bytes

    path = Path(path)  # regular files only, at most defaults.MAX_TOML_BYTES (a FIFO or /dev/zero is refused)
    text = read_input_bytes(path, "rapid").decode("utf-8", errors="replace")
    return parse_rapid(text, str(path), flange)


# -------------------------------------------------------------------------------- path geometry
@dataclass(frozen=True)
class ArcThrough:
    """The circle arc from ``start`` through a via point to ``end``: ``center`` (3,) [m], unit
    ``normal`` (3,) (the sweep is right-handed about it), ``sweep`` in (0, 2 pi) [rad], ``radius`` [m]."""

    start: np.ndarray
    end: np.ndarray
    center: np.ndarray
    normal: np.ndarray
    sweep: float
    radius: float

    @property
    def length(self) -> float:
        return self.sweep * self.radius


def arc_through(p0, p1, p2, where: str = "MoveC") -> ArcThrough:
    """The arc from ``p0`` through ``p1`` to ``p2`` (each (3,) [m]): circumcentre of the triangle."""
    a, b, c = (np.asarray(p, float) for p in (p0, p1, p2))
    ab, ac = b - a, c - a
    nvec = np.cross(ab, ac)
    n2 = float(nvec @ nvec)
    if n2 <= _COLLINEAR**2 * max(ab @ ab, ac @ ac) ** 2:  # |ab x ac|^2 against the squared side^2
        raise ScenarioError(f"{where}: start, circle point and end point are collinear or coincide; move the circle "
                            "point off the line (or use MoveL)")
    center = a + (np.cross(nvec, ab) * (ac @ ac) + np.cross(ac, nvec) * (ab @ ab)) / (2.0 * n2)
    normal = nvec / math.sqrt(n2)
    u = (a - center) / np.linalg.norm(a - center)
    v = np.cross(normal, u)
    w = c - center
    sweep = float(np.arctan2(w @ v, w @ u)) % (2 * math.pi)
    return ArcThrough(a, c, center, normal, sweep, float(np.linalg.norm(a - center)))


def segments(program: RapidProgram) -> list[tuple[RapidMove, np.ndarray, ArcThrough | None, float]]:
    """Per move after the first: (move, start point (3,) [m], the arc or None, length [m])."""
    out = []
    for prev, mv in zip(program.moves[:-1], program.moves[1:]):
        where = f"{program.source}:{mv.line}"
        if mv.kind == "C":
            arc = arc_through(prev.point, mv.via, mv.point, f"{where}: MoveC")
            out.append((mv, prev.point, arc, arc.length))
        else:
            length = float(np.linalg.norm(mv.point - prev.point))
            if length < defaults.MIN_SEGMENT_LENGTH and not mv.joint:  # a joint move may only turn the tool
                raise ScenarioError(f"{where}: the move goes to the point it starts from ({mv.text[:60]}); remove it "
                                    "(a path has no zero-length segments)")
            out.append((mv, prev.point, None, length))
    return out


def effective_zones(program: RapidProgram) -> list[float]:
    """Zone radius [m] at each interior target (corner k between moves k and k+1 after the first):
    the programmed one, reduced as on the controller to half the distance to the neighbouring
    programmed positions (targets and circle points)."""
    out = []
    moves = program.moves
    for k in range(1, len(moves) - 1):
        here = moves[k].point
        near = [moves[k - 1].point, moves[k + 1].point] + [m.via for m in (moves[k], moves[k + 1]) if m.via is not None]
        zone = 0.0 if moves[k].dwell > 0 else moves[k].zone  # a WaitTime stops the robot at the target
        out.append(min([zone] + [0.5 * float(np.linalg.norm(q - here)) for q in near]))
    return out


def _turn(a: np.ndarray, b: np.ndarray) -> float:
    """Angle [rad] of the rotation from ``a`` to ``b`` (3, 3)."""
    return float(np.arccos(np.clip(0.5 * (np.trace(a.T @ b) - 1.0), -1.0, 1.0)))


def orientation_zones(program: RapidProgram) -> list[float]:
    """Orientation zone [m] at each interior target: the path distance either side over which the tool
    turns straight on to the next orientation. The programmed pzone_ori (at least the zone radius),
    reduced to where the turn left to the target is zone_ori (on both neighbouring moves, the turn taken
    as even along each) and, like the zone, to half the neighbouring moves; 0 at fine points and dwells."""
    out = []
    moves, lengths = program.moves, [length for *_, length in segments(program)]
    for k in range(1, len(moves) - 1):
        mv = moves[k]
        if mv.zone == 0.0 or mv.dwell > 0:
            out.append(0.0)
            continue
        size = [mv.zone_ori, 0.5 * lengths[k - 1], 0.5 * lengths[k]]
        for other, length in ((moves[k - 1], lengths[k - 1]), (moves[k + 1], lengths[k])):
            turn = _turn(other.rotation, mv.rotation)
            if turn > _STRAIGHT:
                size.append(length * mv.zone_ori_angle / turn)
        out.append(min(size))
    return out


def segment_speeds(program: RapidProgram) -> list[float]:
    """Programmed TCP speed [m/s] of each move after the first (\\T: its length over the time)."""
    return [mv.speed if mv.speed is not None else length / mv.time for mv, _, _, length in segments(program)]


# ----------------------------------------------------------------------------------- estimate
def rapid_estimate_s(lengths, speeds, zones, turns) -> float:
    """Duration [s] of a program on an ideal constant-speed controller with zone blending.

    ``lengths`` (N,) segment lengths [m]; ``speeds`` (N,) programmed TCP speeds [m/s]; ``zones``
    (N-1,) zone radius at each corner [m] (0 = fine point: the TCP passes the corner, no blend);
    ``turns`` (N-1,) angle between the tangents at each corner [rad]. Each segment runs at its own
    speed; a zone cuts z from both neighbours (at most half of each) and replaces the corner by the
    circular arc tangent to both at the cut points, of length delta z / tan(delta / 2) (2 z as delta
    -> 0), run at the slower neighbour's speed:

        t = sum_i (L_i - cuts_i) / v_i + sum_k blend_k / min(v_k, v_k+1).

    Acceleration is ignored (a fine point costs no time to stop and restart), so this is a lower
    bound of what the real controller achieves on the programmed speeds."""
    L, v, z, d = (np.asarray(x, float).ravel() for x in (lengths, speeds, zones, turns))
    n = len(L)
    if len(v) != n or len(z) != max(n - 1, 0) or len(d) != len(z):
        raise ScenarioError(f"rapid: {len(v)} speeds and {len(z)} zones for a path of {n} segments and {len(d)} "
                            f"corners; give one speed per segment and one zone per corner ({n} and {n - 1})")
    if n == 0 or np.any(v <= 0) or np.any(L <= 0) or np.any(z < 0):
        raise ScenarioError("rapid: lengths and speeds must be positive and zones non-negative")
    cut = np.minimum(z, 0.5 * np.minimum(L[:-1], L[1:]))
    half = 0.5 * d
    straight_join = d < _STRAIGHT
    tan_half = np.tan(np.minimum(half, 0.5 * math.pi - _RIGHT_ANGLE_MARGIN))
    blend = np.where(straight_join, 2.0 * cut, d * cut / np.where(straight_join, 1.0, tan_half))
    straight = L.copy()
    straight[:-1] -= cut
    straight[1:] -= cut
    return float(np.sum(straight / v) + np.sum(blend / np.minimum(v[:-1], v[1:])))


# ----------------------------------------------------------------------------- scenario output
def _num(x: float) -> str:
    v = round(float(x), 12)
    return repr(0.0 if v == 0 else v)


def _vec(v) -> str:
    return "[" + ", ".join(_num(x) for x in v) + "]"


def _orientation(program: RapidProgram) -> str:
    """TOML value of path.orientation: the first target's tool orientation."""
    first = program.moves[0].rotation
    if np.max(np.abs(first - np.array(defaults.TOOL_DOWN_ROTATION))) <= _SAME_ROTATION:
        return '"down"'
    return "[" + ", ".join(_vec(row) for row in first) + "]"


def base_quaternions(program: RapidProgram) -> np.ndarray:
    """Each target's tool orientation in the base frame as a unit quaternion (K, 4) [w, x, y, z], each on
    the side (q or -q, one rotation) nearer the previous one. ScenarioError when two consecutive targets
    are half a turn apart (the direction of the turn is then undefined)."""
    out = np.array([Rotation.from_matrix(m.rotation).as_quat()[[3, 0, 1, 2]] for m in program.moves])
    for k in range(1, len(out)):
        if out[k] @ out[k - 1] < 0.0:
            out[k] = -out[k]
        if out[k] @ out[k - 1] < math.cos(0.5 * (math.pi - _HALF_TURN_MARGIN)):
            a, b = program.moves[k - 1], program.moves[k]
            raise ScenarioError(f"{program.source}:{b.line}: the tool turns half a turn from {a.target} (line "
                                f"{a.line}) to {b.target}, so the direction of the turn is undefined; add a target "
                                "in between")
    return out


def flips(program: RapidProgram) -> list[str]:
    """One sentence per pair of consecutive targets whose written quaternions have opposite signs."""
    out = []
    for a, b in zip(program.moves[:-1], program.moves[1:]):
        if a.quaternion @ b.quaternion < 0.0:
            out.append(f"the quaternions of {a.target} (line {a.line}) and {b.target} (line {b.line}) have opposite "
                       "signs (q and -q are one rotation): the shorter turn between them is taken")
    return out


def notes(program: RapidProgram) -> list[str]:
    """What the scenario does not carry over from the program, one sentence each."""
    out = [f"the first move (line {program.moves[0].line}) only gives the start point"]
    joint = [m.line for m in program.moves[1:] if m.kind == "J"]
    if joint:
        out.append(f"MoveJ at line(s) {', '.join(map(str, joint))}: joint moves, linear in the joints to the IK of "
                   "the target on its robconf")
    absolute = [m.line for m in program.moves if m.kind == "AbsJ"]
    if absolute:
        out.append(f"MoveAbsJ at line(s) {', '.join(map(str, absolute))}: joint moves, linear in the joints to the "
                   "jointtarget's axes (degrees to radians)")
    off = [m.line for m in program.moves if not m.conf and m.robconf is not None]
    if off:
        out.append(f"ConfL/ConfJ \\Off at line(s) {', '.join(map(str, off))}: the configuration there is the one "
                   "continuous with the previous target, the robconf is not checked")
    out += flips(program) + list(program.remarks)
    reduced = [(m.line, m.zone, z) for m, z in zip(program.moves[1:-1], effective_zones(program)) if z < m.zone - _ZONE_ROUNDING]
    for line, zone, z in reduced:
        out.append(f"the zone at line {line} ({zone * 1000:g} mm) is reduced to {z * 1000:.4g} mm, half the distance "
                   "to a neighbouring position, as on the controller")
    if program.unsupported:
        out.append("skipped: " + "; ".join(f"line {ln}: {t}" for ln, t in program.unsupported))
    return out


def check_blend_type(blend: str, what: str) -> None:
    """ScenarioError naming ``what`` unless ``blend`` is one of BLEND_TYPES."""
    if blend not in BLEND_TYPES:
        raise ScenarioError(f"{what}: give g2 (the zone's symmetric blend) or optimal (the fastest blend within the "
                            "same deviation)")


def scenario_toml(program: RapidProgram, tolerances: list[float | None], robot: str = "irb140",
                  name: str | None = None, blend: str = "g2") -> str:
    """Scenario TOML text of ``program``: a task path of its moves, a blend of type ``blend`` ("g2": the
    symmetric G2 blend, "optimal": the fastest G2 blend within the same deviation) with the given
    ``tolerances`` [m] at each corner (None: no blend, a stop), its tool and load, and the ``[rapid]``
    table (speeds per segment [m/s], zones per corner [m]) for :func:`rapid_estimate_s`."""
    check_blend_type(blend, f"blend type {blend!r}")
    segs = segments(program)
    zones = effective_zones(program)
    if len(tolerances) != len(zones):
        raise ScenarioError(f"{program.source}: {len(tolerances)} blend tolerances for {len(zones)} corners")
    name = name or program.module or Path(program.source).stem
    info = notes(program)
    if blend == "optimal" and any(m.joint for m in program.moves[1:]):
        info.append("optimal blends at the zones between MoveL/MoveC; the zones at a MoveJ/MoveAbsJ are joint-space "
                    "zones of the zone's size (type g2), not searched")
    quats = base_quaternions(program)
    t = program.tool
    rpy = matrix_rpy(t.frame.rotation)
    lines = [f"# Imported from the RAPID module {Path(program.source).name} (PROC {program.procedure}) by "
             "`pathmotion import-rapid`.",
             *(f"# Note: {n}." for n in info),
             f"name = {_quote(name)}",
             f"description = {_quote('RAPID ' + Path(program.source).name + ': ' + '; '.join(info))}",
             "", "[robot]", f"name = {_quote(robot)}",
             "", f"[robot.tool]  # tooldata {t.name}: tframe", f"translation = {_vec(t.frame.translation)}",
             f"rotation_rpy = {_vec(rpy)}",
             "", f"[robot.payload]  # tooldata {t.name}: tload", f"mass = {_num(t.mass)}", f"com = {_vec(t.com)}",
             "inertia = [" + ", ".join(_vec(r) for r in t.inertia) + "]",
             "", "[path]", 'type = "task"', f"orientation = {_orientation(program)}",
             *_start(program.moves[0], quats[0]),
             "", f"[path.start_program]  # line {program.moves[0].line}: the start", *_program(program.moves[0])]
    lines += _segment_lines(program, segs, quats)
    corner = _corners(program)
    for k, (tol, z) in enumerate(zip(tolerances, zones)):
        if tol is not None:
            mv = program.moves[k + 1]
            kind = "g2" if mv.joint or program.moves[k + 2].joint else blend  # a joint zone is not searched
            lines += ["", f"[[path.blends]]  # {mv.zone_name} at line {mv.line}: a blend that starts {z * 1000:.4g} mm "
                          "from the target (the zone radius) deviates at most this from the path"
                      + ("" if kind == "g2" else "; the optimal blend stays within it"),
                      f"corner = {corner[k]}", f"type = {_quote(kind)}", f"tolerance = {_num(tol)}"]
    lines += ["", "[plan]", 'start = "zero"', 'end = "zero"',
              "", "[rapid]  # the program's speeds and zones: the summary's rapid_estimate_s",
              f"source = {_quote(Path(program.source).name)}",
              f"speeds = {_vec(segment_speeds(program))}  # programmed TCP speed per segment [m/s]",
              f"zones = {_vec(zones)}  # zone radius per corner [m], 0 = fine point", ""]
    return "\n".join(lines)


def _start(first: RapidMove, quat: np.ndarray) -> list[str]:
    """The start's keys: a MoveAbsJ's axes as the start configuration, else the target as the start pose."""
    if first.joints is not None:
        return [f"start_configuration = {_vec(first.joints)}  # line {first.line}: {first.target[:60]} [rad]"]
    return ["", f"[path.start_pose]  # line {first.line}: {first.target[:60]}, the start",
            f"position = {_vec(first.point)}", f"quaternion = {_vec(quat)}",
            *([f"robconf = [{', '.join(map(str, first.robconf))}]"] if first.robconf else [])]


def _corners(program: RapidProgram) -> list[int]:
    """The scenario's corner number (1-based connection of path.segments) at the end of each move after the first
    but the last: each move is a segment, each WaitTime a dwell segment after its move."""
    out, index = [], 0
    for mv in program.moves[1:-1]:
        index += 1
        out.append(index)
        index += 1 if mv.dwell else 0
    return out


def _segment_lines(program: RapidProgram, segs, quats: np.ndarray) -> list[str]:
    """The [[path.segments]] of the moves after the first: line, arc or joint (MoveJ: a joint move to the
    target's pose on its robconf), each followed by a dwell segment for its WaitTime."""
    lines = []
    ori_zones = [*orientation_zones(program), 0.0]
    for k, (mv, start, arc, _) in enumerate(segs):
        lines += ["", f"[[path.segments]]  # line {mv.line}: {mv.text[:90]}"]
        if mv.joints is not None:
            lines += ['type = "joint"', f"end = {_vec(mv.joints)}  # {mv.target[:40]} [rad]"]
        elif mv.kind == "J":
            lines += ['type = "joint"', "[path.segments.end_pose]", f"position = {_vec(mv.point)}",
                      f"quaternion = {_vec(quats[k + 1])}"]
            lines += [f"robconf = [{', '.join(map(str, mv.robconf))}]"] if mv.robconf else []
        else:
            if arc is None:
                lines += ['type = "line"'] + ([f"start = {_vec(start)}"] if k == 0 else []) + [f"end = {_vec(mv.point)}"]
            else:
                lines += ['type = "arc"'] + ([f"start = {_vec(start)}"] if k == 0 else []) + [
                    f"center = {_vec(arc.center)}", f"normal = {_vec(arc.normal)}", f"sweep = {_num(arc.sweep)}"]
            lines += [f"quaternion = {_vec(quats[k + 1])}  # tool orientation at {mv.target[:40]} in the base frame"]
            if ori_zones[k]:
                lines += [f"orientation_zone = {_num(ori_zones[k])}  # {mv.zone_name}: pzone_ori / zone_ori [m]"]
        lines += ["[path.segments.program]", *_program(mv)]
        if mv.dwell:
            lines += ["", f"[[path.segments]]  # line {mv.dwell_line}: WaitTime", 'type = "dwell"',
                      f"time = {_num(mv.dwell)}", "[path.segments.program]", f"line = {mv.dwell_line}",
                      f"target = {_quote(mv.target[:200])}", 'move = "WaitTime"']
    return lines


def _program(mv: RapidMove) -> list[str]:
    """The keys of a ProgramMoveSpec for ``mv``."""
    out = [f"line = {mv.line}", f"target = {_quote(mv.target[:200])}", f"move = {_quote(mv.instruction)}",
           f"speed = {_num(mv.speed)}" if mv.speed is not None else f"time = {_num(mv.time)}",
           f"zone = {_quote(mv.zone_name)}"]
    if mv.robconf is not None:
        out += [f"robconf = [{', '.join(map(str, mv.robconf))}]", f"conf = {'true' if mv.conf else 'false'}"]
    return out


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'
