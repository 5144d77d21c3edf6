"""Atomic file writes: a temporary file in the same folder, flushed and fsynced, then renamed.

An interrupted write leaves either the previous complete file or the new complete file, never
a half-written one.
"""

from __future__ import annotations

import json
import os
import secrets
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path next to ``path``; on success rename it onto ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # the name is chosen before the file exists, so an interrupt at any moment from its creation on
    # (even inside the call that creates it) finds the name and removes the file
    tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
    try:
        while True:
            try:
                os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
                break
            except FileExistsError:  # another writer's name (48 random bits: practically never)
                tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        _remove(tmp)
        raise

def _remove(tmp: Path) -> None:
    try:
        os.unlink(tmp)
    except FileNotFoundError:
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
