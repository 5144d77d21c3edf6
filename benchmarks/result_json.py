"""The benchmarks' JSON result format, read by benchmarks/results.py to write docs/results.md.

One file holds one table: its title, the command that produced it, the date (UTC), the machine (CPU model,
cores, load average at the start and the end of the run), the columns (key, heading) and the rows (dicts
keyed by column key), plus free-text notes. Written atomically.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import shlex
import sys
from pathlib import Path

from pathmotion.io.atomic import write_text

ROOT = Path(__file__).resolve().parent.parent


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo (else platform.processor())."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def load_average() -> float:
    """The 1-minute load average (0 where the OS has none)."""
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return 0.0


class Table:
    """A result table being measured: start it before the work, ``write`` it after."""

    def __init__(self, title: str, columns: list[tuple[str, str]], command: str | None = None):
        self.title, self.columns, self.rows, self.notes = title, columns, [], []
        script = os.path.relpath(Path(sys.argv[0]).resolve(), ROOT)
        self.command = command or "python " + " ".join(shlex.quote(a) for a in [script, *sys.argv[1:]])
        self.load_start = load_average()
        self.started = datetime.datetime.now(datetime.timezone.utc)

    def add(self, **row) -> None:
        self.rows.append(row)

    def write(self, path: str | Path) -> Path:
        doc = {"title": self.title, "command": self.command,
               "date": self.started.strftime("%Y-%m-%d %H:%M UTC"),
               "machine": {"cpu": cpu_model(), "cores": os.cpu_count(), "load_start": self.load_start,
                           "load_end": load_average()},
               "columns": [{"key": k, "heading": h} for k, h in self.columns],
               "rows": self.rows, "notes": self.notes}
        return write_text(Path(path), json.dumps(doc, indent=1) + "\n")
