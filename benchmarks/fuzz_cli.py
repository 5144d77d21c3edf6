"""The project's own command-line fuzzer: hostile scenario documents through ``check`` and
``plan``, each run in a forked child of a warm server (pathmotion imported once), under a memory limit
(RLIMIT_AS) and a CPU-time limit. One reproducer per escape goes into OUT/escapes.

Escapes: internal error (exit 3), any other exit code than 0/1/2, a traceback, a hang, a memory
kill (a signal or MemoryError), an error that is not one ``error: ...`` line (further validation errors of the same document
indented below it; only ``warning: ...`` lines before it), stderr on success other than ``warning: ...`` and ``note: ...``
lines (a stage's progress line, ``plan: writing (stage 3/3)``, is allowed anywhere), a run that exits 0 without
a complete finite contract file (summary.json, trajectory.csv), a temporary file or folder left behind,
or a folder written by a run that failed.

A hang is judged on the child's own CPU time, not on the wall clock, so that a machine loaded by other jobs
gives no false hangs: RLIMIT_CPU (``--timeout`` seconds of CPU) ends a child that computes too long; a child
that takes no CPU for ``--idle`` seconds while not runnable (blocked, e.g. on a FIFO) is a hang too; a wall
time of ``--wall-cap`` seconds is only the backstop.

    .venv/bin/python benchmarks/fuzz_cli.py --docs 500 --seed 1 [--out out/fuzz] [--workers 2]
    .venv/bin/python benchmarks/fuzz_cli.py --docs 10000 --seed 1 --resume   # resumable, in pieces

Every finished document appends one line to OUT/results-seed{S}-g{GENERATOR}.jsonl (each document depends on
the generator, the seed and its index only); ``--resume`` skips the documents already there without an escape
(one that escaped runs again, to confirm its fix), ``--start N`` begins at document N. The table printed at the
end covers every recorded document of the range: escapes found once, and escapes now.

Each document runs one command (``check`` or ``plan --no-figures``, picked by the seed) on a coarse grid
(plan.grid_points = 50 unless the document sets it): check solves the plan and builds the closed loop's set-up,
so both cover the flow up to writing; ``simulate``'s loop is left out (minutes per document). Prints the
table: documents, escapes found once and escapes now per class, wall and CPU time.
"""

from __future__ import annotations

import argparse
import faulthandler
import json
import math
import os
import random
import resource
import shutil
import signal
import stat
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # the server forks: no BLAS threads in the parent
os.environ.setdefault("OMP_NUM_THREADS", "1")

from pathmotion.cli import PROGRESS_LINE  # noqa: E402 - after the thread settings (numpy is imported lazily there)
from pathmotion.io.files import RESULT_MARK  # noqa: E402 - after the thread settings (a light module)

#: Valid bases, coarse. SQUARE is closed with every corner blended (the closing one included).
JOINT = """name = "joint"
[path]
type = "joint"
waypoints = [[0, 0, 0, 0, 0.5, 0], [0.3, 0.2, -0.2, 0.3, 0.8, 0.5], [0.5, 0.1, 0.0, 0.0, 0.6, 1.0]]
[plan]
grid_points = 50
"""
LINE = """name = "line"
[path]
type = "task"
[[path.segments]]
type = "line"
start = [0.5, -0.1, 0.5]
end = [0.5, 0.1, 0.5]
[plan]
grid_points = 50
"""
SQUARE = """name = "square"
[path]
type = "task"
[[path.segments]]
type = "line"
start = [0.5, -0.1, 0.5]
end = [0.5, 0.1, 0.5]
[[path.segments]]
type = "line"
end = [0.6, 0.1, 0.5]
[[path.segments]]
type = "line"
end = [0.6, -0.1, 0.5]
[[path.segments]]
type = "line"
end = [0.5, -0.1, 0.5]
[[path.blends]]
corner = "all"
type = "circle"
radius = 0.02
[plan]
grid_points = 50
"""
BASES = {"joint": JOINT, "line": LINE, "square": SQUARE}

#: Keys a document may carry (valid or not): renames and insertions draw from these.
KEYS = ["name", "path", "type", "segments", "waypoints", "plan", "limits", "robot", "simulate", "grid_points",
        "start", "end", "velocity", "torque", "radius", "center", "blends", "corner", "tolerance", "periodic",
        "sample_time", "payload", "mass", "com", "inertia", "tool", "translation", "rotation", "gains",
        "bandwidth", "seed", "realism", "use_torque", "tcp_speed", "torque_scale", "orientation", "normal", "sweep"]
EXTREME = [0, -1, -0.0, 1e-300, 1e-9, 1e9, 1e300, 1e308, -1e308, "nan", "inf", "-inf", 2**63, -2**63, 10**30]
#: Where extreme numbers go (key path -> how to build the value from a number).
NUMERIC_SITES = {
    "robot.payload": lambda x: f"mass = 1.0\ncom = [{x}, 0, 0]",
    "robot.payload ": lambda x: f"mass = {x}",
    "robot.payload  ": lambda x: f"mass = 1.0\ninertia = [[1, {x}, 0], [0, 1, 0], [0, 0, 1]]",
    "robot.tool": lambda x: f"translation = [{x}, 0, 0]",
    "simulate": lambda x: f"sample_time = {x}",
    "simulate ": lambda x: f"gains = {{bandwidth = {x}}}",
    "simulate.realism": lambda x: f"seed = {x}",
    "limits": lambda x: f"tcp_speed = {x}",
    "limits ": lambda x: f"torque_scale = {x}",
    "limits  ": lambda x: f"velocity = [{x}, 1, 1, 1, 1, 1]",
    "plan": lambda x: f"sample_time = {x}",
    "plan ": lambda x: f"end = {x}",
}
#: Version of the document generator: part of the results file's name, so that a resumed run never mixes
#: documents of two generators. Bump it when a change alters the documents of a (seed, index).
GENERATOR = 2
CLASSES = ("dropped key", "duplicated key", "renamed key", "wrong type", "garbage bytes", "bad geometry",
           "special file", "deep nesting", "extreme value", "bad --out folder", "closed polygon", "robot files",
           "half a result")
#: The built-in robot's files, the bases of the "robot files" class.
ROBOT_DATA = Path(__file__).resolve().parents[1] / "pathmotion" / "robot" / "data"


@dataclass
class Doc:
    """One hostile document: its class, scenario bytes (or a special path), files beside it, the command."""

    index: int
    klass: str
    data: bytes = b""
    special: str | None = None  # the scenario argument is this special path instead of a file
    files: dict = field(default_factory=dict)  # name -> bytes, or "fifo" / "dir" / "loop"
    command: str = "check"
    out_kind: str = "fresh"  # how --out is prepared (bad --out folder, half a result classes)
    signal: int = 0  # half a result: send this signal to the run ...
    signal_cpu: float = 0.0  # ... once it has used this much CPU time [s]


# ------------------------------------------------------------------------------------ generation
def _lines(text: str) -> list[str]:
    return text.splitlines()


def _toml_value(rng: random.Random, depth: int = 0):
    pick = rng.randrange(9 if depth < 2 else 6)
    if pick == 0:
        return rng.choice(["true", "false"])
    if pick == 1:
        return str(rng.choice([0, 1, -1, 7, 60, 10**9, -(10**9)]))
    if pick == 2:
        return repr(rng.choice([0.5, -0.5, 1e-12, 3.0, 1e12]))
    if pick in (3, 4):
        return json.dumps(rng.choice(["", "x", "all", "zero", "max", "down", "line", "irb140", "orbital", "g2"]))
    if pick == 5:
        return rng.choice(["nan", "inf", "-inf"])
    if pick == 6:
        return "[" + ", ".join(_toml_value(rng, depth + 1) for _ in range(rng.randrange(4))) + "]"
    if pick == 7:
        return "{" + ", ".join(f"{rng.choice(KEYS)}_{i} = {_toml_value(rng, depth + 1)}"
                               for i in range(rng.randrange(3))) + "}"
    return "[[0, 0, 0], [0, 0, 0], [0, 0, 0]]"


def _value_lines(text: str) -> list[int]:
    return [i for i, ln in enumerate(_lines(text)) if "=" in ln and not ln.startswith("[")]


def _replace_value(text: str, rng: random.Random, make) -> str:
    lines = _lines(text)
    i = rng.choice(_value_lines(text))
    key = lines[i].split("=", 1)[0]
    lines[i] = f"{key}= {make()}"
    return "\n".join(lines) + "\n"


def _add_to_table(text: str, table: str, body: str) -> str:
    return text + f"[{table.strip()}]\n{body}\n"


def generate(index: int, rng: random.Random) -> Doc:
    klass = CLASSES[index % len(CLASSES)]
    base_name = rng.choice(sorted(BASES))
    text = BASES[base_name]
    doc = Doc(index, klass, command=rng.choice(["check", "plan"]))
    lines = _lines(text)
    if klass == "dropped key":
        drop = rng.sample(range(len(lines)), rng.randrange(1, 4))
        text = "\n".join(ln for i, ln in enumerate(lines) if i not in drop) + "\n"
    elif klass == "duplicated key":
        i = rng.randrange(len(lines))
        lines.insert(i, lines[i])
        text = "\n".join(lines) + "\n"
    elif klass == "renamed key":
        i = rng.choice(_value_lines(text))
        key, value = lines[i].split("=", 1)
        new = rng.choice([key.strip()[:-1], key.strip() + "s", key.strip().upper(), rng.choice(KEYS), "\"\"",
                          "\"a.b\"", key.strip().replace("_", "-")])
        lines[i] = f"{new} ={value}"
        text = "\n".join(lines) + "\n"
    elif klass == "wrong type":
        text = _replace_value(text, rng, lambda: _toml_value(rng))
    elif klass == "garbage bytes":
        data = bytearray(text.encode())
        for _ in range(rng.randrange(1, 8)):
            pos = rng.randrange(len(data) + 1)
            data[pos:pos + rng.randrange(3)] = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 6)))
        if rng.random() < 0.2:
            data = bytearray(rng.randbytes(rng.randrange(1, 4000)))
        doc.data = bytes(data)
        return doc
    elif klass == "bad geometry":
        text = _bad_geometry(base_name, text, rng)
    elif klass == "special file":
        _special(doc, text, rng)
        return doc
    elif klass == "deep nesting":
        text = _deep(text, rng)
    elif klass == "extreme value":
        site = rng.choice(sorted(NUMERIC_SITES))
        x = rng.choice(EXTREME)
        text = _add_to_table(text, site, NUMERIC_SITES[site](x))
    elif klass == "bad --out folder":
        doc.command = "plan"
        doc.out_kind = rng.choice(["file", "under file", "/dev/null", "/sys", "too long", "read-only",
                                   "result name is a folder", "nul byte", "existing ok"])
    elif klass == "closed polygon":
        corner = rng.choice(['"all"', "0", "1", "3", "4", "5", "-1", "1.5", '"none"'])
        text = SQUARE.replace('corner = "all"', f"corner = {corner}")
        text = text.replace("radius = 0.02", f"radius = {rng.choice([0.001, 0.02, 0.05, 0.099, 0.1, 0.2])}")
        if rng.random() < 0.5:
            text = text.replace("grid_points = 50", "grid_points = 50\nperiodic = true")
        if rng.random() < 0.3:
            text = text.replace('type = "circle"\nradius', 'type = "g2"\ntolerance')
    elif klass == "robot files":
        text = _robot_files(doc, text, rng)
    elif klass == "half a result":
        doc.command = "plan"
        doc.out_kind = rng.choice(["previous result", "previous result", "locked"])
        if doc.out_kind == "previous result":
            doc.signal = rng.choice([signal.SIGINT, signal.SIGTERM])
            doc.signal_cpu = rng.choice([0.01, 0.05, 0.1, 0.2, 0.3, 0.4, 0.6])
        text = BASES[rng.choice(["joint", "line"])]
    doc.data = text.encode()
    return doc


def _bad_geometry(base: str, text: str, rng: random.Random) -> str:
    if base == "joint":
        choice = rng.randrange(4)
        if choice == 0:  # a repeated waypoint
            return text.replace("[[0, 0, 0, 0, 0.5, 0],", "[[0, 0, 0, 0, 0.5, 0], [0, 0, 0, 0, 0.5, 0],")
        if choice == 1:  # outside the ranges
            return text.replace("[0.5, 0.1, 0.0, 0.0, 0.6, 1.0]", f"[{rng.choice([4, 10, -7])}, 0.1, 0, 0, 0.6, 1]")
        if choice == 2:
            return text.replace("waypoints = [", "waypoints = [[0, 0, 0, 0, 0, 0]] + [")
        return text.replace("waypoints = [[0, 0, 0, 0, 0.5, 0], ", "waypoints = [")[:-1] + "\n"
    end = rng.choice(["[0.5, -0.1, 0.5]", "[5.0, 0.1, 0.5]", "[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.8]",
                      "[0.5, 0.1, 0.5000000001]", "[1e-9, 0, 0]", "[0.52, 0.0, 0.5]"])
    choice = rng.randrange(5)
    if choice == 0:
        return text.replace("end = [0.5, 0.1, 0.5]", f"end = {end}", 1)
    if choice == 1:  # a degenerate arc
        return text.replace('type = "line"\nstart = [0.5, -0.1, 0.5]\nend = [0.5, 0.1, 0.5]',
                            f'type = "arc"\nstart = [0.5, -0.1, 0.5]\ncenter = {end}\nnormal = '
                            f'{rng.choice(["[0, 0, 0]", "[0, 0, 1]", "[1, 0, 0]"])}\nsweep = '
                            f'{rng.choice([0, 1e-12, 3.1, 6.3, 100])}', 1)
    if choice == 2:  # a circle of odd radius
        return text.replace('type = "line"\nstart = [0.5, -0.1, 0.5]\nend = [0.5, 0.1, 0.5]',
                            f'type = "circle"\ncenter = [0.5, 0, 0.5]\nradius = {rng.choice([0, 1e-12, 0.3, 5, 1e9])}')
    if choice == 3:  # a tool orientation that is not a rotation
        return text.replace("[plan]", f"orientation = {rng.choice(['[[1,0,0],[0,1,0],[0,0,0]]', '[[2,0,0],[0,1,0],[0,0,1]]', '[[1,0,0],[0,1,0],[0,0,-1]]'])}\n[plan]")
    # through the wrist singularity / a reversal with a blend
    return text.replace("[plan]", '[[path.segments]]\ntype = "line"\nend = [0.5, -0.1, 0.5]\n'
                        '[[path.blends]]\ncorner = 1\ntype = "circle"\nradius = 0.01\n[plan]')


def _special(doc: Doc, text: str, rng: random.Random) -> None:
    where = rng.choice(["scenario", "limits", "urdf"])
    kind = rng.choice(["/dev/zero", "/dev/urandom", "/dev/null", "/proc/self/status", "/dev/tty", "fifo", "dir",
                       "loop", "missing", "long name", "nul"])
    if where == "scenario":
        if kind.startswith("/"):
            doc.special = kind
        elif kind in ("fifo", "dir", "loop"):
            doc.files["s.toml"] = kind
        elif kind == "long name":
            doc.special = "x" * 300 + ".toml"
        elif kind == "nul":
            doc.special = "a\0b.toml"
        return
    key = "limits" if where == "limits" else "name"
    target = kind if kind.startswith("/") else ("x" * 300 if kind == "long name" else "f.dat")
    if kind in ("fifo", "dir", "loop"):
        doc.files["f.dat"] = kind
    value = json.dumps(target).replace("\\u0000", "")
    doc.data = (text + f"[robot]\n{key} = {value}\n").encode()


def _robot_files(doc: Doc, text: str, rng: random.Random) -> str:
    """A hostile limits file or URDF beside the scenario (which names it in [robot])."""
    if rng.random() < 0.5:
        lines = (ROBOT_DATA / "irb140_limits.toml").read_text().splitlines()
        joint_lines = [i for i, ln in enumerate(lines) if "=" in ln and not ln.startswith(("#", "robot", "urdf"))]
        choice = rng.randrange(6)
        if choice == 0:  # a value of the wrong type or out of range (sources of the wrong type included)
            i = rng.choice(joint_lines)
            lines[i] = lines[i].split("=", 1)[0] + "= " + rng.choice(
                ["5", '"x"', "-1.0", "0", "nan", "inf", "1e308", "[]", "{range = 3}", "true", "-1e308"])
        elif choice == 1:  # a line dropped or duplicated
            i = rng.choice(joint_lines)
            lines.insert(i, lines[i]) if rng.random() < 0.5 else lines.pop(i)
        elif choice == 2:  # a joint block (11 lines) less or more
            i = rng.choice([i for i, ln in enumerate(lines) if ln == "[[joints]]"])
            if rng.random() < 0.5:
                lines[i:i] = lines[i:i + 11]
            else:
                del lines[i:i + 11]
        elif choice == 3:  # lower above upper
            lines = [ln.replace("lower = -", "lower = ") for ln in lines]
        elif choice == 4:  # sources of the wrong type everywhere
            lines = [("sources = " + rng.choice(["5", '"official"', "[1, 2]", "{range = 1}"])) if ln.startswith(
                "sources") else ln for ln in lines]
        else:  # garbage bytes inside
            data = bytearray("\n".join(lines).encode())
            for _ in range(rng.randrange(1, 6)):
                pos = rng.randrange(len(data))
                data[pos:pos + 2] = rng.randbytes(rng.randrange(1, 4))
            doc.files["lim.toml"] = bytes(data)
            return text + '[robot]\nlimits = "lim.toml"\n'
        doc.files["lim.toml"] = ("\n".join(lines) + "\n").encode()
        return text + '[robot]\nlimits = "lim.toml"\n'
    urdf = (ROBOT_DATA / "irb140.urdf").read_text()
    choice = rng.randrange(6)
    if choice == 0:  # many links: a chain of fixed joints after tool0
        n = rng.choice([1000, 1001, 20000])
        chain = "".join(f'<link name="x{k}"/><joint name="jx{k}" type="fixed"><parent link="'
                        f'{"tool0" if k == 0 else f"x{k - 1}"}"/><child link="x{k}"/></joint>\n' for k in range(n))
        urdf = urdf.replace("</robot>", chain + "</robot>")
    elif choice == 1:  # over the byte cap: a sparse file of NUL bytes after the text
        doc.files["r.urdf"] = ("sparse", urdf.encode(), rng.choice([50_000_001, 200_000_000]))
        return text + '[robot]\nname = "r.urdf"\n'
    elif choice == 2:  # a mass, inertia, axis or limit that is not physical
        old, new = rng.choice([('mass value="15.99"', f'mass value="{rng.choice(["-1", "0", "nan", "1e308"])}"'),
                               ('ixx="0.3286"', f'ixx="{rng.choice(["-5", "nan", "1e300", "0"])}"'),
                               ('axis xyz="0 1 0"', f'axis xyz="{rng.choice(["0 0 0", "nan 0 0", "1e308 0 0"])}"'),
                               ('effort="350"', f'effort="{rng.choice(["0", "-1", "nan", "inf"])}"'),
                               ('velocity="3.49065850399"', f'velocity="{rng.choice(["0", "-1", "nan"])}"')])
        urdf = urdf.replace(old, new, 1)
    elif choice == 3:  # a structure error: a duplicate or missing link, a loop, a missing robot tag
        old, new = rng.choice([('<link name="link_3">', '<link name="link_2">'),
                               ('<child link="link_4"/>', '<child link="nowhere"/>'),
                               ('<parent link="base_link"/>', '<parent link="link_6"/>'),
                               ("</robot>", ""), ('type="revolute"', 'type="spherical"')])
        urdf = urdf.replace(old, new, 1)
    elif choice == 4:  # garbage bytes
        data = bytearray(urdf.encode())
        for _ in range(rng.randrange(1, 6)):
            pos = rng.randrange(len(data))
            data[pos:pos + 2] = rng.randbytes(rng.randrange(1, 4))
        doc.files["r.urdf"] = bytes(data)
        return text + '[robot]\nname = "r.urdf"\n'
    else:  # deep XML nesting
        depth = rng.choice([100, 10000, 100000])
        urdf = urdf.replace("</robot>", "<a>" * depth + "</a>" * depth + "</robot>")
    doc.files["r.urdf"] = urdf.encode()
    return text + '[robot]\nname = "r.urdf"\n'


def _deep(text: str, rng: random.Random) -> str:
    depth = rng.choice([20, 40, 200, 5000, 100000])
    choice = rng.randrange(3)
    if choice == 0:
        return text + "x = " + "[" * depth + "]" * depth + "\n"
    if choice == 1:
        return text + "a" + ".a" * depth + " = 1\n"
    return text + "x = " + "{a = " * depth + "1" + "}" * depth + "\n"


# ------------------------------------------------------------------------------------ running
@dataclass
class Run:
    doc: Doc
    folder: Path
    args: list
    out: Path | None
    pid: int
    started: float  # monotonic wall clock [s]
    cpu: float = 0.0  # the child's CPU time so far [s]
    progressed: float = 0.0  # monotonic time its CPU time last grew [s]
    hang: str | None = None  # why the parent ended it, when it did
    signalled: bool = False  # half a result: the signal was sent
    lock_fd: int | None = None  # half a result, "locked": the parent holds the --out folder's lock


def _prepare(doc: Doc, folder: Path) -> tuple[list, Path | None]:
    """Files of ``doc`` in ``folder`` and the command's arguments."""
    folder.mkdir(parents=True)
    for name, content in doc.files.items():
        path = folder / name
        if content == "fifo":
            os.mkfifo(path)
        elif content == "dir":
            path.mkdir()
        elif content == "loop":
            os.symlink(path, path)
        elif isinstance(content, tuple):  # ("sparse", head bytes, size): head, then a hole of NUL bytes
            with open(path, "wb") as fh:
                fh.write(content[1])
                fh.truncate(content[2])
        else:
            path.write_bytes(content)
    scenario = folder / "s.toml"
    if "s.toml" not in doc.files and doc.special is None:
        scenario.write_bytes(doc.data)
    scen_arg = doc.special if doc.special is not None else str(scenario)
    if doc.command == "check":
        return ["check", scen_arg], None
    out = folder / "out"
    kind = doc.out_kind
    if kind == "file":
        out.write_text("x")
    elif kind == "under file":
        (folder / "f").write_text("x")
        out = folder / "f" / "out"
    elif kind == "/dev/null":
        out = Path("/dev/null")
    elif kind == "/sys":
        out = Path("/sys/pathmotion-fuzz")
    elif kind == "too long":
        out = folder / ("o" * 300)
    elif kind == "read-only":
        ro = folder / "ro"
        ro.mkdir()
        ro.chmod(stat.S_IRUSR | stat.S_IXUSR)
        out = ro / "out"
    elif kind == "result name is a folder":
        (out / "summary.json").mkdir(parents=True)
    elif kind == "nul byte":
        out = Path(str(folder) + "/o\0ut")
    elif kind in ("previous result", "locked"):
        out.mkdir()
        for name, content in PREVIOUS.items():
            (out / name).write_text(content)
    if doc.klass == "bad --out folder":  # (other classes wrote theirs above; a FIFO must not be written)
        scenario.write_bytes(doc.data or JOINT.encode())
    return ["plan", scen_arg, "--out", str(out), "--no-figures"], out


#: The complete earlier result an interrupted or locked-out run must leave intact (or replace as a whole).
PREVIOUS = {"summary.json": '{"scenario": "previous", "duration_s": 1.0}\n', "trajectory.csv": "t,q1\n0,0\n1,0\n",
            "previous.marker": "the earlier run's folder\n",
            RESULT_MARK: "written by pathmotion; this folder may be replaced by a new result\n"}


def _child(args: list, folder: Path, mem_bytes: int, cpu_s: float) -> None:
    """In the forked child: limits (address space, CPU seconds), output to files, the CLI; never returns."""
    code = 70
    try:
        os.setpgid(0, 0)
        for sig in (signal.SIGTERM, signal.SIGXCPU):
            signal.signal(sig, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)  # Ctrl-C as in a fresh interpreter
        soft = _vm_bytes() + mem_bytes
        resource.setrlimit(resource.RLIMIT_AS, (soft, soft))
        used = sum(os.times()[:2])  # the server's CPU time, inherited by the fork
        cpu = math.ceil(used + cpu_s)
        resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))  # SIGXCPU, then SIGKILL 5 s later
        fd_out = os.open(folder / "stdout.txt", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        fd_err = os.open(folder / "stderr.txt", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(fd_out, 1)
        os.dup2(fd_err, 2)
        # Python-level streams onto the new descriptors too: under pytest (or any host that swapped
        # sys.stdout/sys.stderr for its own capture objects) the CLI would otherwise write elsewhere
        sys.stdout = open(1, "w", encoding="utf-8", errors="replace", closefd=False, buffering=1)
        sys.stderr = open(2, "w", encoding="utf-8", errors="replace", closefd=False, buffering=1)
        faulthandler.enable(file=sys.stderr)  # a crash (SIGSEGV, SIGABRT) leaves its Python stack in stderr.txt
        os.chdir(folder)
        from pathmotion.cli import main

        sys.argv = ["pathmotion", *args]
        try:
            main()
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except MemoryError:
            code = 137
    except BaseException:  # noqa: BLE001 - anything escaping the CLI is the escape being looked for
        import traceback

        traceback.print_exc()
        code = 99
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def _vm_bytes() -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


def _finite_json(path: Path) -> None:
    def refuse(name):
        raise ValueError(f"non-finite {name} in {path.name}")

    json.loads(path.read_text(), parse_constant=refuse)


def _finite_csv(path: Path) -> None:
    import numpy as np

    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if not data.size or not np.all(np.isfinite(data)):
        raise ValueError(f"{path.name} is empty or not finite")


def _proc_stat(pid: int) -> tuple[str, float] | None:
    """(state letter, user + system CPU time [s]) of a running process, from /proc; None once it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return fields[0], (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _warnings(lines: list[str]) -> int:
    """How many of the non-empty stderr ``lines`` at their start are warnings: a ``warning: `` line (the CLI's log
    line at its default verbosity) and the lines indented below it."""
    n = 0
    while n < len(lines) and lines[n].startswith("warning: "):
        n += 1
        while n < len(lines) and lines[n].startswith("  "):
            n += 1
    return n


def verdict(run: Run, status: int | None, elapsed: float, cpu: float = 0.0, cpu_limit: float = 120.0) -> str | None:
    """None when the run behaved, else what escaped. ``status`` is None when the parent ended a hang;
    ``cpu`` is the child's CPU time [s], ``cpu_limit`` its RLIMIT_CPU budget [s]."""
    if status is None:
        return f"hang ({run.hang or 'ended'}; {elapsed:.0f} s wall, {cpu:.1f} s CPU)"
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        if sig == signal.SIGXCPU or (sig == signal.SIGKILL and cpu >= cpu_limit):
            return f"hang (over {cpu_limit:.0f} s of CPU; {elapsed:.0f} s wall)"
        return f"killed by signal {sig} (memory kill?)"
    code = os.WEXITSTATUS(status)
    err = (run.folder / "stderr.txt").read_text(errors="replace")
    out = (run.folder / "stdout.txt").read_text(errors="replace")
    if code == 137:
        return "MemoryError (memory kill)"
    interrupted = code == 130 and run.signalled
    if code not in (0, 1, 2, 4) and not interrupted:  # 4: a failed plan, its files written
        return f"exit {code}" + (" (internal error)" if code == 3 else "") + f": {err.strip()[-300:]}"
    if "Traceback" in err or "Traceback" in out:
        return "traceback"
    lines = [ln for ln in err.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]  # a stage's progress line
    warned = _warnings(lines)  # the warnings logged before the run ended (a corner left sharp), one line each
    lines = lines[warned:]
    # one error: line; several validation errors of one document follow it indented (the CLI's _fail)
    one_line = bool(lines) and lines[0].startswith("error: ") and all(ln.startswith("  ") for ln in lines[1:])
    usage = code == 2 and any("Usage" in ln for ln in lines)  # Typer's own usage error (exit 2)
    # interrupted: the CLI's one 'interrupted' line, or nothing when Typer took the Ctrl-C before the command
    # started (no file written yet)
    if interrupted and not (not lines or (len(lines) == 1 and lines[0].startswith("interrupted"))):
        return f"interrupt not reported in one line ({len(lines)} lines): {err.strip()[:300]}"
    if code and not interrupted and not (one_line or usage):
        return f"error not one line ({len(lines)} lines): {err.strip()[:300]}"
    if code == 0 and any(not ln.startswith("note: ") for ln in lines):  # warnings and notes (an export's) are fine
        return f"stderr on success: {err.strip()[:300]}"
    leftovers = [str(p) for p in run.folder.rglob("*") if p.name.endswith(".tmp")]
    if leftovers:
        return f"temporary left behind: {leftovers[:3]}"
    if run.out is not None and run.out.parent == run.folder:
        return _judge_folder(run, code, err)
    return None


def _contract(out: Path) -> str | None:
    try:
        _finite_json(out / "summary.json")
        _finite_csv(out / "trajectory.csv")
    except (OSError, ValueError) as exc:
        return f"contract file missing or not finite: {exc}"
    return None


def _judge_folder(run: Run, code: int, err: str) -> str | None:
    """The --out folder after the run: a complete finite result when it succeeded (0) or wrote a failed plan
    (4); else no folder (a fresh --out), or the previous result untouched, file for file."""
    kind = run.doc.out_kind
    if kind == "locked" and not (code == 1 and "another pathmotion run" in err):
        return f"a run into a locked folder was not refused (exit {code}): {err.strip()[:200]}"
    if kind not in ("fresh", "previous result", "locked"):
        return None
    if kind != "fresh" and (run.out / "previous.marker").exists():
        now = {p.name: p.read_text(errors="replace") for p in run.out.iterdir() if p.is_file()}
        if now != PREVIOUS or any(p.is_dir() for p in run.out.iterdir()):
            return f"half a result: the previous folder holds {sorted(now)}, changed"
        return None if code not in (0, 4) else f"exit {code} but the previous result is still in --out"
    if code in (0, 4) or (kind != "fresh" and run.out.exists()):  # (an interrupt after the swap: the new one)
        return _contract(run.out)
    if run.out.exists():
        return "a failed run left its --out folder"
    return None if kind == "fresh" else f"exit {code} and no --out folder: the previous result was removed"


def _reproduce(escapes: Path, run: Run, what: str) -> None:
    escapes.mkdir(parents=True, exist_ok=True)
    stem = escapes / f"{run.doc.index:06d}-{run.doc.klass.replace(' ', '_').replace('--', '')}"
    if run.doc.data:
        stem.with_suffix(".toml").write_bytes(run.doc.data)
    stem.with_suffix(".txt").write_text(
        f"class: {run.doc.klass}\nescape: {what}\ncommand: pathmotion {' '.join(map(repr, run.args))}\n"
        f"special: {run.doc.special!r}\nfiles: {sorted(run.doc.files)}\nout: {run.doc.out_kind}\n"
        f"--- stderr\n{_head_and_tail(run.folder / 'stderr.txt')}\n")


def _head_and_tail(path: Path, keep: int = 6000) -> str:
    """The text of ``path``, its middle cut when longer than ``keep`` characters (a crash's faulthandler stack
    starts with the crashing frame: the head matters as much as the tail)."""
    text = path.read_text(errors="replace")
    if len(text) <= keep:
        return text
    return text[:keep // 2] + f"\n[... {len(text) - keep} characters cut ...]\n" + text[-keep // 2:]


def _cleanup(folder: Path) -> None:
    for p in [folder, *folder.rglob("*")]:
        try:
            if p.is_dir() and not p.is_symlink():
                p.chmod(0o755)
        except OSError:
            pass
    shutil.rmtree(folder, ignore_errors=True)


def _results_file(out: Path, seed: int) -> Path:
    return out / f"results-seed{seed}-g{GENERATOR}.jsonl"


def _recorded(path: Path) -> tuple[dict[int, dict], dict[int, dict]]:
    """(latest record of each document run, first escaping record of each document that ever escaped) in
    a results file; a torn last line is ignored."""
    done, escaped = {}, {}
    if path.exists():
        for line in path.read_text().splitlines():
            try:
                rec = json.loads(line)
            except ValueError:
                continue
            done[rec["index"]] = rec
            if rec["escape"]:
                escaped.setdefault(rec["index"], rec)
    return done, escaped


def _doc_rng(seed: int, index: int) -> random.Random:
    """Each document's generator depends on the seed and its index only (so a run can resume anywhere)."""
    return random.Random(f"pathmotion-fuzz-{seed}-{index}")


def _watch(run: Run, now: float, idle: float, wall_cap: float) -> str | None:
    """Why a running child counts as hung (None while it is fine): blocked without CPU progress, or the
    wall-clock backstop. CPU-bound hangs end themselves through RLIMIT_CPU."""
    stat_ = _proc_stat(run.pid)
    if stat_ is not None:
        state, cpu = stat_
        if cpu > run.cpu:
            run.cpu, run.progressed = cpu, now
        if state not in "R" and now - run.progressed > idle:
            return f"blocked (state {state}) without CPU progress for {now - run.progressed:.0f} s"
    if now - run.started > wall_cap:
        return f"over the {wall_cap:.0f} s wall-clock backstop"
    return None


def _launch(doc: Doc, work: Path, mem_mb: int, timeout: float) -> Run:
    folder = work / f"d{doc.index:06d}"
    if folder.exists():
        _cleanup(folder)
    args, out_path = _prepare(doc, folder)
    lock_fd = _hold_lock(out_path) if doc.out_kind == "locked" else None
    pid = os.fork()
    if pid == 0:
        _child(args, folder, mem_mb << 20, timeout)
    now = time.monotonic()
    return Run(doc, folder, args, out_path, pid, now, 0.0, now, lock_fd=lock_fd)


def _hold_lock(out: Path) -> int:
    """Hold the lock another pathmotion run holds while it writes ``out`` (io/atomic.py: an flock on
    .NAME.lock beside it, holding the pid)."""
    import fcntl

    fd = os.open(out.parent / f".{out.name}.lock", os.O_RDWR | os.O_CREAT, 0o644)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    os.write(fd, f"{os.getpid()}\n".encode())
    return fd


def _finish(run: Run, status: int | None, cpu: float, timeout: float, escapes: Path) -> dict:
    """Judge a finished child, keep a reproducer if it escaped, clean up; returns its record."""
    elapsed = time.monotonic() - run.started
    if run.lock_fd is not None:
        os.close(run.lock_fd)
    what = verdict(run, status, elapsed, cpu, timeout)
    if what is not None:
        _reproduce(escapes, run, what)
    try:
        first = (run.folder / "stderr.txt").read_text(errors="replace").strip().splitlines()[0][:160]
    except (OSError, IndexError):
        first = ""
    _cleanup(run.folder)
    code = None if status is None else (os.WEXITSTATUS(status) if os.WIFEXITED(status) else -os.WTERMSIG(status))
    return {"index": run.doc.index, "class": run.doc.klass, "command": run.doc.command, "escape": what,
            "exit": code, "stderr": first, "signalled": run.signalled, "cpu_s": round(cpu, 3),
            "wall_s": round(elapsed, 3)}


def fuzz(docs: int, seed: int, out: Path, workers: int = 2, timeout: float = 120.0, mem_mb: int = 2048,
         start: int = 0, resume: bool = False, idle: float = 120.0, wall_cap: float = 3600.0,
         classes: tuple | None = None) -> dict:
    """Run documents ``start`` .. ``docs - 1`` (skipping those already in the results file when ``resume``);
    ``timeout`` is CPU seconds per document. Returns {"per_class": Counter, "escapes": Counter, "found":
    [(index, class, what)], "seconds": wall time of this call, "ran": documents run by this call, "cpu_s"}
    over every recorded document of the range (of ``classes`` only, when given)."""
    import pathmotion.api  # noqa: F401 - warm the server once: every child starts with it imported
    import pathmotion.cli  # noqa: F401
    from pathmotion import load_robot

    load_robot("irb140").model  # noqa: B018 - the built-in model, parsed once

    results = _results_file(out, seed)
    records, ever = _recorded(results) if resume else ({}, {})
    if not resume and results.exists():
        results.unlink()
    work = Path(tempfile.mkdtemp(prefix="fuzz-", dir=out))
    escapes = out / "escapes"
    running: dict[int, Run] = {}
    t0 = time.monotonic()
    wanted = set(CLASSES if classes is None else classes)
    # a resumed run runs again the documents that escaped (to confirm a fix), and those not run yet
    queue = (i for i in range(start, docs) if (i not in records or records[i]["escape"])
             and CLASSES[i % len(CLASSES)] in wanted)
    pending, ran = True, 0
    with open(results, "a") as log:
        while pending or running:
            while pending and len(running) < workers:
                i = next(queue, None)
                if i is None:
                    pending = False
                    break
                run = _launch(generate(i, _doc_rng(seed, i)), work, mem_mb, timeout)
                running[run.pid] = run
            time.sleep(0.02)
            now = time.monotonic()
            for pid, run in list(running.items()):
                done, status, usage = os.wait4(pid, os.WNOHANG)
                if done == 0:
                    run.hang = _watch(run, now, idle, wall_cap)
                    if run.doc.signal and not run.signalled and run.cpu >= run.doc.signal_cpu:
                        os.killpg(pid, run.doc.signal)  # half a result: interrupt it at this CPU time
                        run.signalled = True
                    if run.hang is None:
                        continue
                    os.killpg(pid, signal.SIGKILL)
                    _, _, usage = os.wait4(pid, 0)
                    status = None
                del running[pid]
                rec = _finish(run, status, usage.ru_utime + usage.ru_stime, timeout, escapes)
                records[rec["index"]] = rec
                if rec["escape"]:
                    ever.setdefault(rec["index"], rec)
                log.write(json.dumps(rec) + "\n")
                log.flush()
                ran += 1
    shutil.rmtree(work, ignore_errors=True)
    mine = [records[i] for i in sorted(records) if start <= i < docs and records[i]["class"] in wanted]
    return {"per_class": Counter(r["class"] for r in mine),
            "escapes": Counter(r["class"] for r in mine if r["escape"]),
            "found_ever": Counter(r["class"] for i, r in ever.items() if start <= i < docs and r["class"] in wanted),
            "found": [(r["index"], r["class"], r["escape"]) for r in mine if r["escape"]],
            "seconds": time.monotonic() - t0, "ran": ran,
            "cpu_s": sum(r["cpu_s"] for r in mine)}


def table(result: dict) -> str:
    ever = result.get("found_ever", result["escapes"])
    rows = [f"{'class':<20} {'documents':>9} {'escaped once':>12} {'escape now':>10}"]
    for klass in CLASSES:
        if not result["per_class"][klass]:
            continue
        rows.append(f"{klass:<20} {result['per_class'][klass]:>9} {ever[klass]:>12} {result['escapes'][klass]:>10}")
    total = sum(result["per_class"].values())
    rows.append(f"{'total':<20} {total:>9} {sum(ever.values()):>12} {sum(result['escapes'].values()):>10}")
    rows.append(f"{result.get('ran', total)} documents run now in {result['seconds']:.0f} s wall; "
                f"{result.get('cpu_s', 0.0):.0f} s of child CPU over all {total}")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--docs", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("out/fuzz"), help="reproducers go to OUT/escapes")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=120.0, help="CPU seconds per document before it is a hang")
    ap.add_argument("--idle", type=float, default=120.0,
                    help="seconds blocked without CPU progress before it is a hang")
    ap.add_argument("--wall-cap", type=float, default=3600.0, help="wall-clock backstop per document [s]")
    ap.add_argument("--mem-mb", type=int, default=2048, help="address space a child may add [MiB]")
    ap.add_argument("--start", type=int, default=0, help="first document index")
    ap.add_argument("--resume", action="store_true",
                    help="keep OUT/results-seed{S}-g{GENERATOR}.jsonl and skip the documents it already holds")
    ap.add_argument("--only", action="append", choices=CLASSES, help="run only this class (repeatable)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    result = fuzz(args.docs, args.seed, args.out.resolve(), args.workers, args.timeout, args.mem_mb,
                  args.start, args.resume, args.idle, args.wall_cap, tuple(args.only) if args.only else None)
    print(table(result))
    for index, klass, what in result["found"]:
        print(f"escape: document {index} ({klass}): {what.splitlines()[0][:200]}")
    sys.exit(1 if result["found"] else 0)


if __name__ == "__main__":
    main()
