"""Write contour_1000.mod: a 1,000-move closed contour (a rounded star of 12 lobes, about 0.8 mm steps at
v500 with z1 zones, tool down) for the program-scale tests and benchmarks. The targets carry the start's
robconf, [0, 0, -2, 0] (axis 6 at -180 deg); the program runs with ``ConfL \\Off``, as a contour whose axis 1 and
6 quadrants change along the way is programmed.

Run from the repository root: ``python tests/data/rapid/make_contour.py`` (deterministic; the
committed file is its output)."""

import math
from pathlib import Path

MOVES = 1000
LOBES = 12
RADIUS_MM, DEPTH_MM = 120.0, 25.0  # mean radius and lobe depth
CENTRE_MM = (480.0, 0.0, 350.0)


def point(k: int) -> tuple[float, float, float]:
    a = 2.0 * math.pi * k / MOVES
    r = RADIUS_MM + DEPTH_MM * math.cos(LOBES * a)
    return (CENTRE_MM[0] + r * math.cos(a), CENTRE_MM[1] + r * math.sin(a), CENTRE_MM[2])


def module() -> str:
    lines = ["! A 1,000-move contour (12-lobed rounded star, about 0.8 mm per move), written by make_contour.py.",
             "MODULE Contour1000",
             "    PERS tooldata tTorch := [TRUE, [[0, 0, 100], [1, 0, 0, 0]], [1, [0, 0, 50], [1, 0, 0, 0], 0, 0, 0]];",
             "    PROC main()",
             "        ConfL \\Off;"]
    for k in range(MOVES + 1):
        x, y, z = point(k)
        zone = "fine" if k in (0, MOVES) else "z1"
        lines.append(f"        MoveL [[{x:.4f}, {y:.4f}, {z:.4f}], [0, 1, 0, 0], [0, 0, -2, 0], "
                     f"[9E9, 9E9, 9E9, 9E9, 9E9, 9E9]], v500, {zone}, tTorch;")
    lines += ["    ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    Path(__file__).with_name("contour_1000.mod").write_text(module())
