"""One rule for every file pathmotion reads, and one for every folder it writes into.

:func:`read_input` reads scenario, limits, URDF and result files: only regular files (no FIFO, device,
terminal, folder, ``/proc`` or ``/sys`` file), at most a stated number of bytes (``defaults.MAX_*_BYTES``;
it reads at most cap + 1 bytes and never trusts a size from ``stat``), UTF-8 text. :func:`parse_toml`
bounds nesting depth and dotted-key depth before ``tomllib`` sees the text. :func:`check_output_dir` checks
an output folder before any work. Every breach is a one-line PathmotionError naming the file and the limit.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .. import defaults
from ..errors import OutputError, PathmotionError, RobotModelError, ScenarioError, printable

#: kind -> (what it is called in messages, name of its byte cap in defaults, error class)
KINDS = {
    "scenario": ("scenario file", "MAX_TOML_BYTES", ScenarioError),
    "limits": ("limits file", "MAX_TOML_BYTES", RobotModelError),
    "urdf": ("URDF file", "MAX_URDF_BYTES", RobotModelError),
    "result": ("result file", "MAX_RESULT_BYTES", PathmotionError),
    "waypoints": ("waypoint file", "MAX_WAYPOINT_FILE_BYTES", ScenarioError),
    "rapid": ("RAPID file", "MAX_TOML_BYTES", ScenarioError),
    "robot": ("robot file", "MAX_TOML_BYTES", RobotModelError),
}
#: Pseudo file systems whose "regular" files report no true size or never end.
_PSEUDO = ("/proc", "/sys", "/dev")

_REASONS = {
    errno.ENOSPC: "the disk is full; free space or choose another folder",
    errno.EDQUOT: "the disk quota is exhausted; free space or choose another folder",
    errno.EROFS: "the file system is read-only; choose another folder",
    errno.EACCES: "permission denied; choose a folder you may write to",
    errno.EPERM: "operation not permitted; choose a folder you may write to",
    errno.ENOTDIR: "a part of the path is a file, not a folder",
    errno.EISDIR: "a folder has that name; remove or rename it",
    errno.ENAMETOOLONG: "the name is too long; choose a shorter path",
    errno.ELOOP: "too many levels of symbolic links (a symlink loop)",
    errno.ENOENT: "it does not exist",
    errno.EEXIST: "it already exists",
    errno.ENXIO: "it is not a regular file (no reader/device behind it)",
}


def os_reason(exc: OSError) -> str:
    """A short reason for an OSError: its meaning and what to change ('disk full', 'read-only', ...)."""
    return _REASONS.get(exc.errno, exc.strerror or type(exc).__name__)


def _is_pseudo(path: Path) -> bool:
    try:
        real = os.path.realpath(path)
    except (OSError, ValueError):
        return False
    return any(real == p or real.startswith(p + "/") for p in _PSEUDO)


def _check_name(path: str, what: str, error: type) -> None:
    if "\0" in path:
        raise error(f"{what} {path!r} contains a NUL byte; give a plain file name")
    if len(os.fsencode(path)) > defaults.MAX_PATH_BYTES or any(
            len(os.fsencode(part)) > defaults.MAX_NAME_BYTES for part in Path(path).parts):
        raise error(f"{what} {printable(path[:60])}... is too long (more than {defaults.MAX_NAME_BYTES} bytes per "
                    f"name or {defaults.MAX_PATH_BYTES} in all); give a shorter path")


def read_input_bytes(path: str | Path, kind: str) -> bytes:
    """The bytes of a regular file of ``kind`` (see KINDS), at most its cap; an error naming the file
    and the limit otherwise (missing, not a regular file, special file, too large, unreadable)."""
    what, cap_name, error = KINDS[kind]
    cap = getattr(defaults, cap_name)
    name = os.fspath(path)
    _check_name(name, what, error)
    shown = printable(name)
    if _is_pseudo(Path(name)):
        raise error(f"{what} {shown} is in /proc, /sys or /dev, not a regular file; give a file")
    try:  # O_NONBLOCK: opening a FIFO with no writer must not hang; O_NOCTTY: a tty never becomes ours
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        if exc.errno == errno.ENOENT:
            raise error(f"{what} {shown} does not exist") from None
        raise error(f"{what} {shown} cannot be read: {os_reason(exc)}") from None
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise error(f"{what} {shown} is a folder; give a file")
        if not stat.S_ISREG(mode):
            raise error(f"{what} {shown} is not a regular file (a FIFO, device or socket); give a file")
        chunks, total = [], 0
        while total <= cap:
            chunk = os.read(fd, min(1 << 20, cap + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > cap:
            raise error(f"{what} {shown} is larger than {cap:,} bytes (defaults.{cap_name}); give a smaller file")
        return b"".join(chunks)
    except OSError as exc:
        raise error(f"{what} {shown} cannot be read: {os_reason(exc)}") from None
    finally:
        os.close(fd)


def read_input(path: str | Path, kind: str) -> str:
    """:func:`read_input_bytes` decoded as UTF-8 (an error naming the file when it is not)."""
    data = read_input_bytes(path, kind)
    what, _, error = KINDS[kind]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{what} {printable(os.fspath(path))} cannot be read: not UTF-8 text (byte {exc.start}); "
                    "save it as UTF-8") from None


# ------------------------------------------------------------------------------------------ TOML
# Strings and comments; each alternative, once started, always matches (an unterminated string runs to the
# end of its line or of the text) and its loops are possessive, so the scan never backtracks: linear time.
_STRINGS = re.compile(r'"""(?:[^"\\]|\\[\s\S]?|"(?!""))*+(?:"{3,5}|\Z)'
                      r"|'''(?:[^']|'(?!''))*+(?:'{3,5}|\Z)"
                      r'|"(?:[^"\\\n]|\\.?)*+(?:"|$)'
                      r"|'[^'\n]*+(?:'|$)"
                      r"|#[^\n]*+", re.M)


def toml_depth(text: str) -> tuple[int, int]:
    """(deepest nesting of arrays and inline tables, most parts of one dotted key) of TOML text,
    counted outside strings and comments in linear time (an upper bound: a float adds a key part)."""
    import numpy as np

    bare = np.frombuffer(_STRINGS.sub("s", text).encode("utf-8", "replace"), dtype=np.uint8)
    if not bare.size:
        return 0, 1
    step = np.isin(bare, np.frombuffer(b"[{", np.uint8)).astype(np.int64)
    step -= np.isin(bare, np.frombuffer(b"]}", np.uint8))
    nesting = max(int(np.cumsum(step).max()), 0)
    dots = np.concatenate(([0], np.cumsum(bare == ord("."))))
    breaks = np.concatenate(([0], np.flatnonzero(np.isin(bare, np.frombuffer(b"=,\n[]{}", np.uint8))), [bare.size]))
    keys = int(np.diff(dots[breaks]).max()) + 1  # dots between consecutive breaks
    return nesting, keys


def parse_toml(text: str, where: str, error: type = ScenarioError) -> dict:
    """``tomllib.loads`` with the depth limits checked first (defaults.MAX_TOML_DEPTH)."""
    import tomllib

    nesting, keys = toml_depth(text)
    limit = defaults.MAX_TOML_DEPTH
    if nesting > limit:
        raise error(f"{where}: arrays or inline tables nested {nesting} deep, more than {limit} "
                    "(defaults.MAX_TOML_DEPTH); flatten the document")
    if keys > limit:
        raise error(f"{where}: a dotted key of {keys} parts, more than {limit} (defaults.MAX_TOML_DEPTH); "
                    "use shorter key paths")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{where}: not valid TOML: {exc}") from None
    except ValueError:  # tomllib's int() of a number beyond Python's int-to-str digit limit (4,300 digits)
        raise error(f"{where}: an integer of more than {sys.get_int_max_str_digits():,} digits, far beyond any "
                    "limit; give a number of sensible size") from None
    except RecursionError:
        raise error(f"{where}: nested too deeply to parse (defaults.MAX_TOML_DEPTH); flatten the document") from None


# ------------------------------------------------------------------------------------- outputs
def check_output_dir(out: str | Path, keep=()) -> Path:
    """Check, before any work, that ``out`` is (or can be created as) a writable folder: not a file, not
    under a file, not in /proc, /sys or /dev, not too long, on a writable file system, and replaceable
    (:func:`check_replaceable`, ``keep``: the run's input files). Creates nothing."""
    name = os.fspath(out)
    _check_name(name, "output folder", OutputError)
    shown = printable(name)
    path = Path(name)
    if len(os.fsencode(path.name)) > defaults.MAX_NAME_BYTES - 40:  # room for the temporary sibling's name
        raise OutputError(f"output folder {printable(name[:60])}...: its name is too long (more than "
                          f"{defaults.MAX_NAME_BYTES - 40} bytes); give a shorter name")
    if _is_pseudo(path.absolute()):
        raise OutputError(f"output folder {shown} is in /proc, /sys or /dev; choose a folder on a disk")
    if path.exists() and not path.is_dir():
        raise OutputError(f"output folder {shown} is a file, not a folder; choose another --out")
    ancestor = path.absolute().parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise OutputError(f"output folder {shown} lies under {ancestor}, which is a file; choose another --out")
    check_replaceable(path, keep)
    try:  # the only sure test of writability (root ignores permission bits, a read-only mount does not)
        os.rmdir(tempfile.mkdtemp(prefix=".pathmotion-probe-", dir=ancestor))
    except OSError as exc:
        raise OutputError(f"output folder {shown} cannot be created in {ancestor}: {os_reason(exc)}") from None
    return path


#: The file every result folder holds: only a folder with it (or an empty or missing one) may be replaced.
RESULT_MARK = ".pathmotion-result"


def _holds(folder: str, inner: str) -> bool:
    """True when the real path ``inner`` is ``folder`` or lies inside it."""
    return inner == folder or inner.startswith(folder.rstrip("/") + "/")


def check_replaceable(out: str | Path, keep=()) -> None:
    """Refuse an output folder whose replacement could lose files that are not a result: a symbolic link,
    a folder holding the current folder, the home folder or any of ``keep`` (the run's input files), and a
    non-empty folder without :data:`RESULT_MARK`. Paths are compared after resolving symbolic links."""
    name = os.fspath(out)
    shown = printable(name)
    path = Path(name)
    if path.is_symlink():
        raise OutputError(f"output folder {shown} is a symbolic link (to {printable(os.readlink(path))}); "
                          "give a new folder as --out, not a link")
    real = os.path.realpath(path)
    guarded = [(os.getcwd(), "the current folder"), (str(Path.home()), "your home folder")]
    guarded += [(str(Path(k).absolute().parent), f"the input {printable(os.fspath(k))}") for k in keep]
    for folder, what in guarded:
        if _holds(real, os.path.realpath(folder)):
            raise OutputError(f"output folder {shown} ({printable(real)}) is or holds {what}, which a result "
                              "folder would replace; give a new folder, e.g. --out out/run")
    if path.is_dir() and not (path / RESULT_MARK).exists():
        try:
            entries = next(os.scandir(path), None)
        except OSError as exc:
            raise OutputError(f"output folder {shown} cannot be read: {os_reason(exc)}") from None
        if entries is not None:
            raise OutputError(f"output folder {shown} holds files that are not a pathmotion result (no "
                              f"{RESULT_MARK} in it), which a result folder would replace; give a new or empty "
                              "folder as --out, or remove its files")


def mark_result(folder: str | Path) -> None:
    """Create ``folder`` if needed and put :data:`RESULT_MARK` in it (a folder written in place)."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not (folder / RESULT_MARK).exists():
            (folder / RESULT_MARK).write_text("written by pathmotion; this folder may be replaced by a new result\n")
    except OSError as exc:
        raise output_error(exc, folder / RESULT_MARK) from None


def check_output_file(out: str | Path, inputs=()) -> Path:
    """Check an output file's name before any work: not empty, not an existing folder, not one of ``inputs``."""
    name = os.fspath(out)
    if name in ("", "."):
        raise OutputError("output file name is empty or '.'; give a file name, e.g. --out result.toml")
    _check_name(name, "output file", OutputError)
    path = Path(name)
    if path.is_dir():
        raise OutputError(f"output file {printable(name)} is a folder; give a file name in it")
    for k in inputs:
        if os.path.exists(k) and os.path.realpath(k) == os.path.realpath(path):
            raise OutputError(f"output file {printable(name)} is the input {printable(os.fspath(k))}, which it "
                              "would overwrite; give another file name")
    return path


def output_error(exc: OSError, path: str | Path | None = None) -> OutputError:
    """An OutputError naming the file (``path``, else the error's own) and the reason."""
    name = os.fspath(path) if path is not None else (exc.filename or "an output file")
    return OutputError(f"cannot write {printable(name)}: {os_reason(exc)}")


@contextmanager
def captured_fd2():
    """Redirect the C-level stderr (file descriptor 2) into a temporary file while the block runs; yields
    a list that holds the captured text lines afterwards (C libraries such as urdfdom print there)."""
    import sys

    lines: list[str] = []
    try:
        sys.stderr.flush()
    except (AttributeError, ValueError, OSError):
        pass
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield lines
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            lines.extend(ln.strip() for ln in tmp.read(1 << 16).decode("utf-8", "replace").splitlines() if ln.strip())
