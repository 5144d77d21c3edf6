"""A generated contour program of N 12 mm moves (90 deg saw-teeth in rows, rows stepping outwards, layers upwards:
the shape of a gluing or deburring raster), as a scenario: straight segments with a blend at every corner.

    python benchmarks/program_contour.py 1000 --blend g2 --tolerance 0.0005 > contour.toml
"""

from __future__ import annotations

import argparse

LEG = 0.012  #: move length [m]
WIDTH = 0.30  #: row length [m]
ROW_GAP = 0.02  #: distance between rows [m]
ROWS = 12  #: rows per layer
LAYER = 0.01  #: height between layers [m]
ORIGIN = (0.40, -0.15, 0.40)  #: first target [m], in front of an IRB140


def points(n: int) -> list[tuple[float, float, float]]:
    """The N + 1 targets [m] of an N-move contour."""
    d = LEG / 2 ** 0.5
    per_row = int(WIDTH / d)
    pts: list[tuple[float, float, float]] = []
    r = 0
    while len(pts) < n + 1:
        layer, row = divmod(r, ROWS)
        for k in range(per_row + 1):
            y = ORIGIN[1] + (k * d if r % 2 == 0 else WIDTH - k * d)
            pts.append((ORIGIN[0] + row * ROW_GAP + (d if k % 2 else 0.0), y, ORIGIN[2] + layer * LAYER))
        r += 1
    return pts[: n + 1]


def scenario(n: int, blend: str = "g2", tolerance: float = 0.0005, search: str | None = None) -> str:
    """The scenario TOML of an N-move contour with ``blend`` ("g2" | "optimal" | "none") at every corner."""
    pts = points(n)
    lines = [f'name = "contour{n}"', "[robot]", 'name = "irb140"', "[path]", 'type = "task"']
    for i in range(1, n + 1):
        lines += ["[[path.segments]]", 'type = "line"']
        if i == 1:
            lines.append("start = [%.6f, %.6f, %.6f]" % pts[0])
        lines.append("end = [%.6f, %.6f, %.6f]" % pts[i])
    if blend != "none":
        lines += ["[[path.blends]]", 'corner = "all"', f'type = "{blend}"', f"tolerance = {tolerance!r}"]
        if search is not None:
            lines.append(f'search = "{search}"')
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("moves", type=int)
    ap.add_argument("--blend", default="g2", choices=("g2", "optimal", "none"))
    ap.add_argument("--tolerance", type=float, default=0.0005, help="blend tolerance [m]")
    ap.add_argument("--search", choices=("fast", "thorough"), default=None)
    a = ap.parse_args()
    print(scenario(a.moves, a.blend, a.tolerance, a.search), end="")


if __name__ == "__main__":
    main()
