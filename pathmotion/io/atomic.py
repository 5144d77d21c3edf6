"""Atomic file writes: a temporary file in the same folder, flushed and fsynced, then renamed; and
atomic result folders (:func:`result_folder`): a temporary sibling folder swapped in at the end.

An interrupted write leaves either the previous complete file (folder) or the new complete one, never
a half-written one. Files get the permissions of an ordinary ``open`` (0o666 less the umask). A failed
write raises an OutputError naming the file and the reason (disk full, read-only, ...).
"""

from __future__ import annotations

import errno
import json
import os
import secrets
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .files import check_replaceable, mark_result, output_error


def umask() -> int:
    """The process umask (read from /proc/self/status when possible: setting it to read it is racy)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path next to ``path``; on success rename it onto ``path``."""
    path = Path(path)
    # the name is chosen before the file exists, so an interrupt at any moment from its creation on
    # (even inside the call that creates it) finds the name and removes the file
    tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
    try:
        try:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except FileExistsError:  # a file where a folder of the path belongs
                raise OSError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(path.parent)) from None
            while True:
                try:  # mode 0o666: the kernel applies the umask, as for any file a program creates
                    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
                    break
                except FileExistsError:  # another writer's name (48 random bits: practically never)
                    tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
        except OSError as exc:
            raise output_error(exc, path) from None
        try:
            yield tmp
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        except OSError as exc:
            raise output_error(exc, path) from None
    except BaseException:
        _remove(tmp)
        raise

def _remove(tmp: Path) -> None:
    try:
        os.unlink(tmp)
    except OSError:  # never created (or its folder could not be): nothing to remove
        pass


def write_text(path: str | Path, text: str) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_json(path: str | Path, obj) -> Path:
    """Strict JSON with sorted keys: +-inf written as the strings "inf" / "-inf" (an unbounded ratio,
    e.g. a velocity jump; ``float("inf")`` reads it back), NaN as null."""
    return write_text(path, json.dumps(_strict(obj), indent=2, sort_keys=True) + "\n")


def _strict(obj):
    import math

    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _strict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_strict(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_strict(v) for v in obj.tolist()]
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return v if math.isfinite(v) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


# ------------------------------------------------------------------------------- result folders
#: Lock files held by this process: path -> [file descriptor, nesting depth].
_HELD: dict[str, list] = {}


def _lock_path(out: Path) -> Path:
    return out.parent / f".{out.name}.lock"


def _read_pid(fd: int) -> str:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, 32).decode("ascii", "replace").strip() or "unknown"
    except OSError:
        return "unknown"


def _acquire(lock: Path, out: Path) -> int:
    """An fd holding an exclusive flock on ``lock`` with our pid written in it. A lock left by a dead run
    is free (the kernel drops a dead process's flocks) and is taken over; a live one is an error."""
    import fcntl

    from ..errors import OutputError

    for _ in range(20):
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o666 & ~umask())
        except OSError as exc:
            raise output_error(exc, lock) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = _read_pid(fd)
            os.close(fd)
            raise OutputError(f"another pathmotion run (pid {pid}) is writing to {out} (lock {lock}); wait for it "
                              "to finish or choose another --out") from None
        try:  # its previous holder may have removed the file between our open and our lock: retry then
            same = os.stat(lock).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode("ascii"))
            return fd
        os.close(fd)
    raise OutputError(f"cannot take the lock {lock} of {out}: it keeps changing; is another run starting there?")


@contextmanager
def output_lock(out: str | Path):
    """Hold the lock file ``.NAME.lock`` beside the folder ``out`` while the block runs (re-entrant
    within a process); another run into the same folder meanwhile gets an error naming this pid."""
    out = Path(out).absolute()
    lock = _lock_path(out)
    key = str(lock)
    if key in _HELD:
        _HELD[key][1] += 1
        try:
            yield
        finally:
            _HELD[key][1] -= 1
        return
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise output_error(exc, out) from None
    fd = _acquire(lock, out)
    _HELD[key] = [fd, 1]
    try:
        yield
    finally:
        del _HELD[key]
        try:
            os.unlink(lock)
        except OSError:
            pass
        os.close(fd)


def _siblings(out: Path, kind: str) -> list[Path]:
    return sorted(out.parent.glob(f".{glob_escape(out.name)}.pm-{kind}-*.tmp"))


def glob_escape(name: str) -> str:
    import glob

    return glob.escape(name)


def _clean_stale(out: Path) -> None:
    """Remove temporary siblings an interrupted or killed run left (the lock is held); when it was killed
    between the two renames of a swap (no ``out``, an old copy left), put the old folder back."""
    import shutil

    olds = _siblings(out, "old")
    if olds and not out.exists():
        os.rename(olds[-1], out)
        olds = olds[:-1]
    for stale in (*_siblings(out, "new"), *olds):
        shutil.rmtree(stale, ignore_errors=True)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux renameat2 RENAME_EXCHANGE); False where unsupported."""
    import ctypes
    import errno

    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _swap_in(new: Path, out: Path) -> None:
    """Put the complete folder ``new`` at ``out``; the previous ``out`` stays until this succeeded."""
    import shutil

    if not os.path.lexists(out):
        os.rename(new, out)
        return
    if _exchange(new, out):
        shutil.rmtree(new, ignore_errors=True)  # ``new`` now holds the previous folder
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.pm-old-", suffix=".tmp", dir=out.parent))
    os.rename(out, old)  # (renames a folder onto the empty one just made)
    try:
        os.rename(new, out)
    except BaseException:
        os.rename(old, out)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _new_sibling(out: Path) -> Path:
    return out.parent / f".{out.name}.pm-new-{secrets.token_hex(6)}.tmp"


@contextmanager
def result_folder(out: str | Path):
    """Yield a new temporary sibling folder of ``out`` to write a run's files into; when the block ends
    without an error it replaces ``out`` as one unit (atomic exchange where the OS has it, else two
    renames with the old folder kept until the new one is in place). On an error or interrupt the
    temporary folder is removed and ``out`` is untouched. Holds the lock of ``out`` meanwhile and first
    removes what an earlier interrupted run left. Only a folder :func:`~.files.check_replaceable` allows is
    replaced; the new one holds the mark :data:`~.files.RESULT_MARK`."""
    import shutil

    out = Path(out).absolute()
    with output_lock(out):
        check_replaceable(out)
        try:
            _clean_stale(out)
        except OSError as exc:
            raise output_error(exc, out) from None
        # the name is chosen before the folder exists, so an interrupt at any moment from its creation on
        # (even inside the call that creates it) finds the name and removes the folder
        new = _new_sibling(out)
        try:
            try:
                while True:
                    try:  # mode 0o777: the kernel applies the umask, as for any folder a program creates
                        os.mkdir(new, 0o777)
                        break
                    except FileExistsError:  # another run's name (48 random bits: practically never)
                        new = _new_sibling(out)
            except OSError as exc:
                raise output_error(exc, out) from None
            mark_result(new)
            yield new
            try:
                _swap_in(new, out)
            except OSError as exc:
                raise output_error(exc, out) from None
        except BaseException:
            shutil.rmtree(new, ignore_errors=True)
            raise
