"""On-disk cache of the controller's set-up: the path table and the orbital design (gains, Riccati matrices).

Building them costs more than simulating a short motion (a path lifted by inverse kinematics at every table
point, the Riccati sweep), and a scenario is typically simulated again and again with the same path and plan.
Entries are .npz files in :func:`cache_dir`, named by a SHA-256 key of everything they depend on:

* the table: the path's class, domain, breaks, kinks, closedness and its (Phi, Phi', Phi'') at
  ``FINGERPRINT_POINTS`` theta values (a changed path changes them), and the number of table points;
* the design, in addition: the profile's grid, x* and holds (dwells), the gains, the sample time, the delay
  and the design kind;
* both: this format's version, every number in :mod:`pathmotion.defaults` and the source of the control
  package (a change of either invalidates every entry).

Writes are atomic (a temporary file renamed into place; not fsynced, see :func:`_write`). A read checks the key
stored inside, the shapes and that every number is finite; an entry that fails (corrupt, truncated, foreign) is
ignored with a warning and rebuilt. ``PATHMOTION_CACHE_DIR`` chooses the folder; the value ``off`` turns the cache off.
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np

from .. import defaults
from .gains import OrbitalGains
from .orbital import OrbitalDesign, RiccatiKnots
from .path_table import PathTable
from .profile_lookup import ProfileLookup
from .transverse import TransverseBasis

log = logging.getLogger(__name__)

#: Version of the entries' layout; bump it when the arrays stored change meaning.
FORMAT_VERSION = 1
#: theta values at which the path is sampled for its fingerprint [-].
FINGERPRINT_POINTS = 33
#: Environment variable naming the cache folder ("off": no cache).
ENV = "PATHMOTION_CACHE_DIR"


def cache_dir() -> Path | None:
    """The cache folder: $PATHMOTION_CACHE_DIR, else $XDG_CACHE_HOME/pathmotion, else ~/.cache/pathmotion;
    None when $PATHMOTION_CACHE_DIR is "off"."""
    chosen = os.environ.get(ENV)
    if chosen:
        return None if chosen.strip().lower() == "off" else Path(chosen)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "pathmotion"


@lru_cache(maxsize=1)
def _source_digest() -> bytes:
    """Digest of the control package's source (read once per process)."""
    h = hashlib.sha256(f"format {FORMAT_VERSION}".encode())
    for f in sorted(Path(__file__).parent.glob("*.py")):
        h.update(f.name.encode() + f.read_bytes())
    return h.digest()


def _code_digest() -> bytes:
    """Digest of the control package's source and of every number in defaults (read at each call)."""
    h = hashlib.sha256(_source_digest())
    for name in sorted(vars(defaults)):
        value = getattr(defaults, name)
        if name.isupper() and isinstance(value, (int, float, str, bool)):
            h.update(f"{name}={value!r};".encode())
    return h.digest()


def _update(h, *arrays) -> None:
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=float)
        h.update(str(a.shape).encode() + a.tobytes())


def table_key(path, points: int) -> str:
    """Key of the table of ``path`` with ``points`` points (the path evaluated at FINGERPRINT_POINTS thetas)."""
    h = hashlib.sha256(_code_digest())
    lo, hi = path.domain
    h.update(f"{type(path).__module__}.{type(path).__qualname__} n={path.n} closed={bool(path.closed)} "
             f"points={int(points)}".encode())
    _update(h, [lo, hi], sorted(path.breaks), sorted(path.kinks), *path.evaluate(np.linspace(lo, hi, FINGERPRINT_POINTS)))
    return h.hexdigest()


def design_key(table_hash: str, profile, gains: OrbitalGains, sample_time: float | None, delay: int) -> str:
    """Key of the orbital design on the table ``table_hash`` for ``profile`` with these gains and sampling."""
    h = hashlib.sha256(table_hash.encode())
    h.update(f"{gains!r} sample_time={sample_time!r} delay={int(delay)}".encode())
    _update(h, profile.grid, profile.x)
    if profile.holds is not None:  # the dwells move the clock zones (a profile without them keeps its key)
        _update(h, profile.holds)
    return h.hexdigest()


def _read(folder: Path | None, name: str, key: str) -> dict | None:
    """The arrays of entry ``name`` if it exists and holds ``key`` and only finite numbers, else None."""
    if folder is None:
        return None
    file = folder / f"{name}.npz"
    if not file.exists():
        return None
    try:
        with np.load(file, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
        if str(data.pop("key")) != key:
            raise ValueError("key mismatch")
        if not all(np.all(np.isfinite(v)) for v in data.values() if v.dtype.kind == "f"):
            raise ValueError("non-finite numbers")
        return data
    except Exception as exc:  # noqa: BLE001 - any unreadable entry is rebuilt
        log.warning("ignoring the controller cache entry %s (%s); rebuilding it", file, exc)
        return None


def _write(folder: Path | None, name: str, key: str, **arrays) -> None:
    """Entry ``name``: the arrays saved straight into a temporary file in ``folder``, renamed into place. Not
    fsynced (a design entry is ~10 MB; the fsync and an in-memory copy cost more than the loop of a 1 s motion):
    an entry a system crash leaves torn fails :func:`_read`'s checks and is rebuilt."""
    if folder is None:
        return
    file = folder / f"{name}.npz"
    tmp = None
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=f".{name}.", suffix=".tmp", delete=False) as fh:
            tmp = Path(fh.name)
            np.savez(fh, key=np.array(key), **arrays)
        os.replace(tmp, file)
    except Exception as exc:  # noqa: BLE001 - a cache that cannot be written only costs time
        log.warning("could not write the controller cache entry %s (%s)", file, exc)
        if tmp is not None:
            tmp.unlink(missing_ok=True)


def cached_table(path, points: int = defaults.PATH_TABLE_POINTS, folder: Path | None = None) -> tuple[PathTable, str]:
    """(PathTable.from_path(path, points), its key), read from the cache when a valid entry exists."""
    folder = cache_dir() if folder is None else folder
    key = table_key(path, points)
    data = _read(folder, f"table-{key}", key)
    if data is not None:
        grid, coeffs = data["grid"], data["coeffs"]
        if coeffs.shape == (len(grid) - 1, 6, path.n) and np.all(np.diff(grid) > 0):
            lo, hi = path.domain
            return PathTable(grid=grid, coeffs=coeffs, domain=(float(lo), float(hi)), closed=bool(path.closed),
                             n=path.n, kinks=data["kinks"]), key
        log.warning("ignoring the controller cache entry table-%s (inconsistent shapes); rebuilding it", key)
    table = PathTable.from_path(path, points)
    _write(folder, f"table-{key}", key, grid=table.grid, coeffs=table.coeffs, kinks=table.kinks)
    return table, key


def cached_design(path, profile, gains: OrbitalGains = OrbitalGains(), sample_time: float | None = None,
                  delay: int = 0, points: int = defaults.PATH_TABLE_POINTS, folder: Path | None = None
                  ) -> OrbitalDesign:
    """OrbitalDesign.build(table of ``path``, profile, gains, sample_time, delay), table and design read from
    the cache when valid entries exist (written otherwise)."""
    folder = cache_dir() if folder is None else folder
    table, tkey = cached_table(path, points, folder)
    key = design_key(tkey, profile, gains, sample_time, delay)
    data = _read(folder, f"design-{key}", key)
    if data is not None:
        m, n = len(table.grid), table.n
        gain, zones = data["gain"], data["zones"].reshape(-1, 2)
        d = gain.shape[2] if gain.ndim == 3 else -1
        riccati = _riccati_knots(data, m, d)
        if gain.shape == (m, n, d) and riccati is not None and np.array_equal(data["theta"], table.grid):
            basis = TransverseBasis(int(data["basis_k"]), float(data["basis_sigma"]))
            log.info("closed-loop design: orbital controller read from the cache (%s)", folder / f"design-{key}.npz")
            return OrbitalDesign(table, ProfileLookup(profile, closed=table.closed), basis, gains, table.grid, gain,
                                 riccati, tuple((float(a), float(b)) for a, b in zones))
        log.warning("ignoring the controller cache entry design-%s (inconsistent shapes); rebuilding it", key)
    log.info("closed-loop design: orbital controller (transverse linearization, %s Riccati)",
             "continuous" if sample_time is None else "sampled")
    design = OrbitalDesign.build(table, profile, gains, sample_time, delay)
    knots = design.riccati_knots
    _write(folder, f"design-{key}", key, theta=design.theta, gain=design.gain,
           riccati_segments=np.array([[s.start, s.stop, len(s.knots)] for s in knots], dtype=np.int64).reshape(-1, 3),
           riccati_knots=np.concatenate([np.zeros(0, np.int64)] + [s.knots for s in knots]),
           riccati_values=np.concatenate([np.zeros((0,) + design.gain.shape[2:] * 2)] + [s.values for s in knots]),
           zones=np.asarray(design.zones, float).reshape(-1, 2), basis_k=np.array(design.basis.k),
           basis_sigma=np.array(design.basis.sigma))
    return design


def _riccati_knots(data: dict, m: int, d: int) -> tuple[RiccatiKnots, ...] | None:
    """The design's Riccati knots from a cache entry (grid of ``m`` points, state size ``d``), None when absent or
    inconsistent."""
    try:
        rows, knots, values = data["riccati_segments"], data["riccati_knots"], data["riccati_values"]
    except KeyError:
        return None
    counts = rows[:, 2] if rows.ndim == 2 and rows.shape[1] == 3 else None
    if counts is None or np.any(counts < 1) or knots.shape != (counts.sum(),) or values.shape != (len(knots), d, d) \
            or np.any(rows[:, 0] < 0) or np.any(rows[:, 1] > m) or np.any(rows[:, 0] >= rows[:, 1]):
        return None
    ends = np.cumsum(counts)
    return tuple(RiccatiKnots(int(a), int(b), knots[e - c:e], values[e - c:e])
                 for (a, b, c), e in zip(rows, ends))
