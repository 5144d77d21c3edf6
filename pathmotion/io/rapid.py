"""ABB RAPID programs as input: parse a module into plain data, write it as a scenario.

What is read (keywords are case-insensitive; ``!`` starts a comment; a statement runs to its ``;``
over any number of lines):

* ``CONST`` / ``PERS`` / ``VAR`` declarations of ``robtarget`` ([[x, y, z] mm, [q1..q4],
  [cf1, cf4, cf6, cfx], [eax_a..eax_f]]), ``tooldata``, ``wobjdata``, ``speeddata``,
  ``zonedata`` and ``num``; other data types are ignored (data, not motion).
* ``MoveL`` / ``MoveJ`` / ``MoveC`` in ``PROC main`` (or the only procedure with moves), with
  targets given by name, inline, as ``Offs(p, dx, dy, dz)`` or ``RelTool(p, dx, dy, dz)``; speeds
  ``v5`` ... ``v7000``, custom speeddata (its ``v_tcp``), ``\\V:=`` [mm/s] and ``\\T:=`` [s]; zones
  ``fine``, ``z0`` ... ``z200`` (ABB's table of TCP zone radii), custom zonedata (``pzone_tcp``)
  and ``\\Z:=``; the tool (``tframe``, and ``tload`` as the payload) and ``\\WObj:=`` (``uframe``
  and ``oframe``).

Frames: a robtarget is the TCP pose in the object frame, so the TCP pose in the robot base frame is
T_base_tcp = T_uframe T_oframe T_target (quaternions [q1, q2, q3, q4] = [w, x, y, z]). The robot base
is the world frame (no ``baseframe``). Positions are converted from mm to m.

What it is not: a RAPID interpreter. Control flow, procedure calls, assignments at run time, I/O,
waits and every other motion instruction (``MoveAbsJ``, ``SearchL``, ``TriggL``, ``ConfL``,
``SingArea``, ...) are listed as unsupported with their line numbers: an error unless skipped.

Modelling choices, also written into the scenario:

* ``MoveJ`` moves the joints, not the TCP along a line; it becomes a straight line in task space
  (flagged in the scenario's description).
* The first move's target is the path's start: where the robot comes from is not in the program.
* A task path has one tool orientation today: the targets' common one, or the first target's with a
  warning when they differ.
* A zone is the sphere around the target where ABB's corner path starts; as on the controller it is
  reduced to half the distance to the neighbouring programmed positions. A fine point is a stop (a
  sharp corner; the planner stops at sharp corners; a fine point between two collinear moves is not
  a stop in the plan).

:func:`rapid_estimate_s` is the program's duration on an ideal constant-speed controller with zone
blending: a lower bound of what the real controller achieves (it ignores acceleration).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import defaults
from ..errors import ScenarioError

#: ABB's predefined speeddata: v_tcp [mm/s].
SPEEDS_MM_S = {f"v{v}": float(v) for v in (5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600,
                                           800, 1000, 1500, 2000, 2500, 3000, 4000, 5000, 6000, 7000)}
#: ABB's predefined zonedata: pzone_tcp [mm] (fine = stop point, 0).
ZONES_MM = {"fine": 0.0, "z0": 0.3, "z1": 1.0, "z5": 5.0, "z10": 10.0, "z15": 15.0, "z20": 20.0, "z30": 30.0,
            "z40": 40.0, "z50": 50.0, "z60": 60.0, "z80": 80.0, "z100": 100.0, "z150": 150.0, "z200": 200.0}
#: Statements that neither move the robot nor change its motion or timing.
_HARMLESS = {"tpwrite", "tperase", "errwrite", "tpshow"}
#: Block keywords: their lines carry no ``;``.
_BLOCKS = {"module", "endmodule", "proc", "endproc", "func", "endfunc", "trap", "endtrap", "if", "else",
           "elseif", "endif", "for", "endfor", "while", "endwhile", "test", "case", "default", "endtest",
           "error", "undo", "backward", "local", "task"}
_MOVE_ARGS = {"movel": ("to", "speed", "zone", "tool"), "movej": ("to", "speed", "zone", "tool"),
              "movec": ("via", "to", "speed", "zone", "tool")}
_OPTIONAL = {"v", "t", "z", "wobj", "conc", "inpos", "id"}
_SAME_ROTATION = 1e-6  # largest element difference of two rotation matrices taken as equal [-]
_GIMBAL_LOCK = 1e-12  # cos(pitch) below which roll and yaw are one turn (all put in roll) [-]
_COLLINEAR = 1e-9  # |ab x ac| / (longest side)^2 below which three circle points are a line [-]
_STRAIGHT = 1e-9  # corner turn angle below which a zone is taken as a straight join [rad]
_RIGHT_ANGLE_MARGIN = 1e-15  # keeps tan(half turn) finite at a full reversal [rad]
#: The blends an import can write at each zone: the zone's symmetric G2 blend, or the fastest within its deviation.
BLEND_TYPES = ("g2", "optimal")
_ZONE_ROUNDING = 1e-12  # a zone reduced by less than this is not reported as reduced [m]


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
    """One Move instruction: ``kind`` "L", "J" or "C"; ``point`` (3,) TCP target in the base frame [m];
    ``rotation`` (3, 3) TCP orientation in the base frame; ``via`` (3,) MoveC circle point [m];
    ``speed`` v_tcp [m/s] (None when ``time`` [s] is given by ``\\T``); ``zone`` programmed zone
    radius [m] (0 = fine point)."""

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


@dataclass(frozen=True)
class RapidProgram:
    """A parsed RAPID module: the moves of its main procedure, the one tool they use and the
    statements that were not understood, as (line, text)."""

    source: str
    module: str
    procedure: str
    moves: tuple[RapidMove, ...]
    tool: RapidTool
    unsupported: tuple[tuple[int, str], ...]


# ------------------------------------------------------------------------------------- helpers
def quaternion_matrix(q, where: str = "quaternion") -> np.ndarray:
    """Rotation matrix (3, 3) of an ABB quaternion [q1, q2, q3, q4] = [w, x, y, z] (normalized here;
    ScenarioError if it is far from unit length)."""
    w, x, y, z = (float(v) for v in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not abs(n - 1.0) < 1e-3:
        raise ScenarioError(f"{where}: quaternion {list(q)} has norm {n:.6g}, not 1; give a unit quaternion "
                            "[q1, q2, q3, q4] = [w, x, y, z]")
    w, x, y, z = w / n, x / n, y / n, z / n
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

    def __init__(self, where: str):
        self.where = where
        self.data: dict[str, tuple[str, object, int]] = {}  # name (lower) -> (type, value, line)
        self.module = ""
        self.procs: dict[str, list] = {}
        self.unsupported: dict[str, list[tuple[int, str]]] = {"": []}
        self.proc = ""

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
        v = self.value(text, line)
        if not isinstance(v, float):
            self.fail(line, f"expected a number, got {text.strip()[:40]!r}")
        return v

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
        if dtype in ("robtarget", "tooldata", "wobjdata", "speeddata", "zonedata", "num"):
            self.data[name.lower()] = (dtype, self.value(init, line), line)

    # --- frames ---------------------------------------------------------------------------------
    def pose(self, value, line: int, what: str) -> Frame:
        try:
            trans, quat = value[0], value[1]
            p = np.array([float(v) for v in trans], float) / 1000.0
            if p.shape != (3,):
                raise ValueError
            return Frame(p, quaternion_matrix(quat, f"{self.where}:{line}: {what}"))
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
        t = text.strip()
        m = re.fullmatch(r"(?is)(offs|reltool)\s*\((.*)\)", t)
        if m:
            args = _split_top(m.group(2))
            if any(a.startswith("\\") or "\\" in a for a in args) or len(args) != 4:
                self.fail(line, f"{m.group(1)}(...) with rotations or {len(args)} arguments is not supported; use "
                                f"{m.group(1)}(p, dx, dy, dz) in mm")
            base = self.target(args[0], line)
            d = np.array([self.number(a, line) for a in args[1:]]) / 1000.0
            shift = d if m.group(1).lower() == "offs" else base.rotation @ d
            return Frame(base.translation + shift, base.rotation)
        if t.lower() in self.data and self.data[t.lower()][0] != "robtarget":
            self.fail(line, f"{t} is a {self.data[t.lower()][0]}, not a robtarget")
        if not t.startswith("[") and t.lower() not in self.data:
            self.fail(line, f"robtarget {t!r} is not declared with a value; declare CONST robtarget {t} := [...] "
                            "before the move (run-time assignments are not evaluated)")
        return self.pose(self.value(t, line), line, f"robtarget {t[:40]}")

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

    def zone(self, text: str, opts: dict, line: int) -> tuple[float, str]:
        """(zone radius [m], its name); 0 for fine."""
        name = text.strip()
        if name.lower() in ZONES_MM and name.lower() not in self.data:
            z = ZONES_MM[name.lower()]
        else:
            zd = self.typed(name, "zonedata", line) if name.lower() in self.data or "[" in name else None
            if not isinstance(zd, list) or len(zd) < 2:
                self.fail(line, f"zone {name!r}: give fine, z0 ... z200 or a zonedata [finep, pzone_tcp, ...]")
            z = 0.0 if zd[0] is True else float(zd[1])
        if "z" in opts:
            z = self.number(opts["z"], line)
            name = f"{name}\\Z:={z:g}"
        if z < 0:
            self.fail(line, f"zone {name!r}: the zone radius must not be negative")
        return z / 1000.0, name

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
                                    "\\V, \\T, \\Z, \\WObj, \\Conc, \\Inpos, \\ID); remove it")
                opts[key] = val.strip()
            if head.strip():
                mains.append(head.strip())
        if len(mains) != len(names):
            self.fail(line, f"{kind} needs {len(names)} arguments ({', '.join(names)}), got {len(mains)}: {text[:80]}")
        a = dict(zip(names, mains))
        tool = self.tool(a["tool"], line)
        obj = self.wobj(opts["wobj"], line) if opts.get("wobj") else Frame()
        tcp = obj @ self.target(a["to"], line)
        via = (obj @ self.target(a["via"], line)).translation if "via" in a else None
        speed, time = self.speed(a["speed"], opts, line)
        zone, zone_name = self.zone(a["zone"], opts, line)
        return RapidMove(kind[-1].upper(), line, " ".join(text.split()), tcp.translation, tcp.rotation, via,
                         speed, time, zone, zone_name, tool.name)

    def statement(self, line: int, text: str) -> None:
        word = re.match(r"[A-Za-z_]\w*", text)
        head = word.group(0).lower() if word else ""
        decl = re.fullmatch(r"(?is)(?:(?:local|task)\s+)?(const|pers|var)\s+(\w+)\s+(\w+)\s*(\{[^}]*\})?"
                            r"\s*(?::=\s*(.*))?", text)
        if decl:
            self.declaration(line, decl)
        elif head == "module":
            self.module = text.split()[1].split("(")[0] if len(text.split()) > 1 else ""
        elif head in ("proc", "local") and re.match(r"(?i)(local\s+)?proc\s+(\w+)", text):
            self.proc = re.match(r"(?i)(local\s+)?proc\s+(\w+)", text).group(2)
            self.procs.setdefault(self.proc, [])
            self.unsupported.setdefault(self.proc, [])
        elif head == "endproc":
            self.proc = ""
        elif head == "endmodule" or head in _HARMLESS:
            pass
        elif head in _MOVE_ARGS and self.proc:
            self.procs[self.proc].append(self.move(line, head, text[len(head):], text))
        else:
            why = " (control flow is not followed)" if head in _BLOCKS else ""
            self.unsupported[self.proc].append((line, " ".join(text.split())[:80] + why))


def parse_rapid(text: str, source: str = "program.mod") -> RapidProgram:
    """Parse RAPID module text (``source`` names it in errors: "file:line: what; what to change").

    Reads ``PROC main``, or the only procedure with moves. ScenarioError if there are no moves, if
    the moves use more than one tool, or on a value it cannot read."""
    p = _Parser(source)
    for line, stmt in _statements(text):
        p.statement(line, stmt)
    with_moves = [name for name, moves in p.procs.items() if moves]
    main = next((name for name in p.procs if name.lower() == "main"), None)
    if main is None and len(with_moves) > 1:
        raise ScenarioError(f"{source}: procedures {', '.join(with_moves)} all have moves and there is no PROC main; "
                            "the import reads PROC main or the only procedure with moves")
    proc = main or (with_moves[0] if with_moves else "")
    moves = tuple(p.procs.get(proc, []))
    if len(moves) < 2:
        raise ScenarioError(f"{source}: {'PROC ' + proc if proc else 'the module'} has {len(moves)} MoveL/MoveJ/MoveC "
                            "instructions; a path needs at least two (the first target is the start point)")
    tools = sorted({m.tool for m in moves}, key=str.lower)
    if len({t.lower() for t in tools}) > 1:
        raise ScenarioError(f"{source}: the moves use tools {', '.join(tools)}; a scenario has one tool: use one "
                            "tooldata in every move")
    tool = p.tool(moves[0].tool, moves[0].line)
    unsupported = tuple(sorted(p.unsupported[""] + p.unsupported.get(proc, [])))
    return RapidProgram(source, p.module, proc, moves, tool, unsupported)


def read_rapid(path: str | Path) -> RapidProgram:
    """Read and parse a RAPID module file (see :func:`parse_rapid`)."""
    from .files import read_input_bytes

    path = Path(path)  # regular files only, at most defaults.MAX_TOML_BYTES (a FIFO or /dev/zero is refused)
    text = read_input_bytes(path, "rapid").decode("utf-8", errors="replace")
    return parse_rapid(text, str(path))


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
            if length < defaults.MIN_SEGMENT_LENGTH:
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
        out.append(min([moves[k].zone] + [0.5 * float(np.linalg.norm(q - here)) for q in near]))
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


def _orientation(program: RapidProgram) -> tuple[str, str | None]:
    """(TOML value of path.orientation, warning or None)."""
    first = program.moves[0].rotation
    differ = [m.line for m in program.moves if np.max(np.abs(m.rotation - first)) > _SAME_ROTATION]
    warning = None
    if differ:
        warning = (f"the targets' tool orientations differ (first at line {differ[0]}); a task path has one orientation: "
                   f"the first target's (line {program.moves[0].line}) is used throughout")
    if np.max(np.abs(first - np.array(defaults.TOOL_DOWN_ROTATION))) <= _SAME_ROTATION:
        return '"down"', warning
    return "[" + ", ".join(_vec(row) for row in first) + "]", warning


def notes(program: RapidProgram) -> list[str]:
    """What the scenario does not carry over from the program, one sentence each."""
    out = [f"the first move (line {program.moves[0].line}) only gives the start point"]
    joint = [m.line for m in program.moves[1:] if m.kind == "J"]
    if joint:
        out.append(f"MoveJ at line(s) {', '.join(map(str, joint))} planned as straight TCP lines (joint "
                   "interpolation is not a task path)")
    warning = _orientation(program)[1]
    if warning:
        out.append(warning)
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
             "", "[path]", 'type = "task"', f"orientation = {_orientation(program)[0]}"]
    for k, (mv, start, arc, _) in enumerate(segs):
        lines += ["", f"[[path.segments]]  # line {mv.line}: {mv.text[:90]}"]
        if arc is None:
            lines += ['type = "line"'] + ([f"start = {_vec(start)}"] if k == 0 else []) + [f"end = {_vec(mv.point)}"]
        else:
            lines += ['type = "arc"'] + ([f"start = {_vec(start)}"] if k == 0 else []) + [
                f"center = {_vec(arc.center)}", f"normal = {_vec(arc.normal)}", f"sweep = {_num(arc.sweep)}"]
    for k, (tol, z) in enumerate(zip(tolerances, zones)):
        if tol is not None:
            mv = program.moves[k + 1]
            lines += ["", f"[[path.blends]]  # {mv.zone_name} at line {mv.line}: a blend that starts {z * 1000:.4g} mm "
                          "from the target (the zone radius) deviates at most this from the path"
                      + ("" if blend == "g2" else "; the optimal blend stays within it"),
                      f"corner = {k + 1}", f"type = {_quote(blend)}", f"tolerance = {_num(tol)}"]
    lines += ["", "[plan]", 'start = "zero"', 'end = "zero"',
              "", "[rapid]  # the program's speeds and zones: the summary's rapid_estimate_s",
              f"source = {_quote(Path(program.source).name)}",
              f"speeds = {_vec(segment_speeds(program))}  # programmed TCP speed per segment [m/s]",
              f"zones = {_vec(zones)}  # zone radius per corner [m], 0 = fine point", ""]
    return "\n".join(lines)


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'
