"""Parameter sweeps: the same plan + simulate flow run once per point, in parallel.

Points are the Cartesian product of ``--set NAME=V1,V2,...`` values (NAME is a scenario key path,
e.g. ``path.blends[0].radius``), in the order the values are given (the last name varies fastest).
Each finished point is written at once, atomically, as its own JSON file ``DIR/points/KEY.json``
(and ``KEY.npz`` with its time series when traces are on); ``sweep.csv`` and ``sweep.parquet`` are
rebuilt from them after every point, so an interrupted sweep keeps every finished row and a re-run
with the same ``DIR`` resumes: points already done are skipped. A point's KEY hashes the scenario
text and its overrides, so editing the scenario recomputes every point. A failing point is a row
with its ``error``, never a stopped sweep.

Table columns: the parameters (key paths), then :data:`~pathmotion.study.point.SUMMARY_KEYS`, then
``error``. Executors: local processes (default, ``workers`` of them; 1 = in this process) or a Dask
distributed cluster (``scheduler="tcp://HOST:PORT"``). Both run :func:`~pathmotion.study.point.run_point`
on the same inputs, so their tables are identical.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from ..errors import ScenarioError
from ..io.atomic import atomic_path, write_json, write_text
from ..io.files import mark_result
from ..io import schema
from ..io.scenario import parse_value
from ..io.processes import WorkerPool, completed
from ..io.scheduler import dask_client
from .point import SUMMARY_KEYS, run_point

log = logging.getLogger(__name__)

#: A sweep's progress callback: on_result(done, total) after each finished point (and once at the start).
OnResult = Callable[[int, int], None]


@dataclass(frozen=True)
class SweepPoint:
    """One point: its index in the product, the scenario overrides {key path: value} as pairs, and
    the digest of the scenario text it belongs to."""

    index: int
    overrides: tuple[tuple[str, Any], ...]
    scenario_digest: str = ""

    @property
    def key(self) -> str:
        text = json.dumps([self.scenario_digest, [list(kv) for kv in self.overrides]], sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def split_values(text: str) -> list[str]:
    """"0.1,[1, 2],x" -> ["0.1", "[1, 2]", "x"]: commas inside brackets or braces do not split."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        depth += ch in "[{"
        depth -= ch in "]}"
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    return [p for p in parts if p.strip()]


def parse_sets(sets: Iterable[str]) -> dict[str, list]:
    """["a.b=1,2", "c=x"] -> {"a.b": [1, 2], "c": ["x"]} (values as :func:`pathmotion.io.scenario.parse_value`
    reads them; TOML arrays keep their commas); errors name the bad item."""
    out: dict[str, list] = {}
    for item in sets:
        if "=" not in item:
            raise ScenarioError(f"--set {item!r}: expected NAME=V1,V2,... (e.g. path.blends[0].radius=0.03,0.04)")
        name, values = item.split("=", 1)
        name = name.strip()
        vals = [parse_value(v) for v in split_values(values)]
        if not name or not vals:
            raise ScenarioError(f"--set {item!r}: needs a key path and at least one value")
        if name in out:
            raise ScenarioError(f"--set {name} given twice; give all its values in one --set")
        if len(set(map(repr, vals))) != len(vals):
            raise ScenarioError(f"--set {item!r}: a value is repeated; give each value once")
        out[name] = vals
    if not out:
        raise ScenarioError("a sweep needs at least one --set NAME=V1,V2,...")
    return out


def scenario_digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def sweep_points(grid: dict[str, list], digest: str = "") -> list[SweepPoint]:
    """The Cartesian product of ``grid`` (an empty grid is the one point without overrides)."""
    names = list(grid)
    return [SweepPoint(i, tuple(zip(names, combo)), digest)
            for i, combo in enumerate(itertools.product(*grid.values()))]


# ------------------------------------------------------------------------------------- files
def _points_dir(out: Path) -> Path:
    return out / "points"


def load_finished(out: Path) -> dict[str, dict]:
    """Finished point records in ``out/points`` by key (what a resumed sweep skips)."""
    done = {}
    folder = _points_dir(out)
    if folder.is_dir():
        for f in sorted(folder.glob("*.json")):
            try:
                rec = json.loads(f.read_text())
                done[rec["key"]] = rec
            except (json.JSONDecodeError, OSError, KeyError, TypeError):
                continue  # never a half file (atomic writes), but be safe: such a point reruns
    return done


def load_trace(out: str | Path, point: SweepPoint) -> dict[str, np.ndarray] | None:
    """The time series of a finished traced point (see point.trace_arrays), or None."""
    f = _points_dir(Path(out)) / f"{point.key}.npz"
    if not f.is_file():
        return None
    with np.load(f) as data:
        return {k: data[k] for k in data.files}


def _record(out: Path, point: SweepPoint, result: dict) -> dict:
    """Write a finished point (trace first, so a JSON file always has its trace); its record."""
    trace = result.get("trace")
    if trace:
        with atomic_path(_points_dir(out) / f"{point.key}.npz") as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, **trace)
    rec = {"key": point.key, "index": point.index, "overrides": [list(kv) for kv in point.overrides],
           "summary": result["summary"], "error": result["error"], schema.WALL_TIME.key: result.get(schema.WALL_TIME.key),
           "traced": bool(trace)}
    write_json(_points_dir(out) / f"{point.key}.json", rec)
    return json.loads(json.dumps(rec))


def table_rows(points: list[SweepPoint], finished: dict[str, dict]) -> list[dict]:
    """One row per finished point, in point order: parameters, SUMMARY_KEYS, error."""
    rows = []
    for p in points:
        rec = finished.get(p.key)
        if rec is None:
            continue
        row = {name: value for name, value in p.overrides}
        row.update({k: rec["summary"].get(k) for k in SUMMARY_KEYS})
        row["error"] = rec["error"]
        rows.append(row)
    return rows


def write_tables(out: Path, rows: list[dict], names: list[str], stem: str = "sweep") -> None:
    """STEM.csv and STEM.parquet in ``out`` with the columns ``names`` (atomic writes)."""
    lines = [",".join(names)] + [",".join(_csv_cell(r.get(n)) for n in names) for r in rows]
    write_text(out / f"{stem}.csv", "\n".join(lines) + "\n")
    import pyarrow as pa
    import pyarrow.parquet as pq

    cols = {}
    for n in names:
        vals = [r.get(n) for r in rows]
        present = [v for v in vals if v is not None]
        if present and all(isinstance(v, bool) for v in present):
            cols[n] = pa.array(vals, type=pa.bool_())
        elif all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in present):
            cols[n] = pa.array([None if v is None else float(v) for v in vals], type=pa.float64())
        else:
            cols[n] = pa.array([None if v is None else str(v) for v in vals], type=pa.string())
    with atomic_path(out / f"{stem}.parquet") as tmp:
        pq.write_table(pa.table(cols), tmp)


def _csv_cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (float, np.floating)):
        return repr(float(v)) if math.isfinite(v) else ""
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    s = str(v).replace('"', '""')
    return f'"{s}"' if ("," in s or '"' in s or "\n" in s) else s


# ----------------------------------------------------------------------------------- running
def read_scenario(scenario_path: str | Path) -> tuple[str, str]:
    """(TOML text, absolute folder of the file) of a scenario, or a ScenarioError."""
    from ..io.files import read_input

    scenario_path = Path(scenario_path)
    text = read_input(scenario_path, "scenario")
    return text, str(scenario_path.resolve().parent)


def run_sweep(scenario_path: str | Path, grid: dict[str, list], out: str | Path, *, workers: int = 2,
              scheduler: str | None = None, on_result: OnResult | None = None, traces: bool = False,
              point_fn: Callable = run_point) -> tuple[list[SweepPoint], list[dict]]:
    """Run every point of ``grid`` not finished yet in ``out``; returns (points, rows), the rows in
    point order. ``traces``: keep each point's time series (points/KEY.npz) for figures."""
    out = Path(out)
    text, base_dir = read_scenario(scenario_path)
    points = sweep_points(grid, scenario_digest(text))
    names = [*grid, *SUMMARY_KEYS, "error"]
    mark_result(out)
    _points_dir(out).mkdir(parents=True, exist_ok=True)
    write_json(out / "sweep_spec.json", {"scenario": str(scenario_path), "grid": grid, "columns": names})
    finished = load_finished(out)
    todo = [p for p in points if p.key not in finished or (traces and not finished[p.key].get("traced")
                                                            and finished[p.key]["error"] is None)]
    done = len(points) - len(todo)
    log.info("sweep into %s: %d points, %d finished already, %d to run (%s)", out, len(points), done, len(todo),
             f"Dask at {scheduler}" if scheduler else f"{workers} worker process(es)")
    if on_result:
        on_result(done, len(points))

    def record(point: SweepPoint, result: dict) -> None:
        nonlocal done
        finished[point.key] = _record(out, point, result)
        log.debug("point %d %s: %s", point.index, dict(point.overrides), result["error"] or "ok")
        write_tables(out, table_rows(points, finished), names)
        done += 1
        if on_result:
            on_result(done, len(points))

    if todo:
        args = (text, base_dir)
        if scheduler:
            _run_dask(scheduler, args, todo, record, point_fn, traces)
        elif workers <= 1 or len(todo) == 1:
            for p in todo:
                record(p, point_fn(*args, p.overrides, traces))
        else:
            _run_processes(workers, args, todo, record, point_fn, traces)
    rows = table_rows(points, finished)
    write_tables(out, rows, names)
    return points, rows


def _lost(exc: BaseException) -> dict:
    """The result of a point whose worker died (the point itself never returned)."""
    summary = {k: None for k in SUMMARY_KEYS}
    return {"summary": summary, "error": f"worker failed: {type(exc).__name__}: {exc}", "trace": None}


def _run_processes(workers: int, args, todo, record, point_fn, traces) -> None:
    """The points on local worker processes, each recorded as it finishes; an interrupt (Ctrl-C, SIGTERM) drops
    the queued points and stops the running ones now: every finished point is already on disk, so a re-run
    resumes from there."""
    with WorkerPool(min(workers, len(todo))) as pool:
        futures = {pool.submit(point_fn, *args, p.overrides, traces): p for p in todo}
        for fut in completed(futures):
            try:
                result = fut.result()
            except Exception as exc:  # a crashed worker process: record it, keep the others
                result = _lost(exc)
            record(futures[fut], result)


def _run_dask(address: str, args, todo, record, point_fn, traces) -> None:
    from distributed import as_completed as dask_completed

    with dask_client(address) as client:
        futures = {client.submit(point_fn, *args, p.overrides, traces, key=f"pathmotion-point-{p.key}", pure=False): p
                   for p in todo}
        for fut in dask_completed(list(futures)):
            try:
                result = fut.result()
            except Exception as exc:  # a lost worker: record it, keep the others
                result = _lost(exc)
            record(futures[fut], result)
