"""A blend the search's coarse grid misjudges.

On the 90 degree turn at 10 mm the blend search (SEARCH_GRID_POINTS = 300 per fast plan) ranked this shape
fastest of every stage, at 0.550 s; on any finer grid it takes 0.73 s. Its corner quintic is 0.6 mm long with a
curvature peak of about 5500 1/m (radius 0.18 mm). The search's full-grid candidates and polish then ended at
0.5754 s, where a tolerance smaller by 1e-9 (relative) gave 0.5703 s. This script plans the shape on several fixed
grids and on the default adaptive one, and prints the blended path's pieces and curvature peak.

    python benchmarks/search_grid_artifact.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from right_turn import TURN  # noqa: E402  (the 90 degree turn, defined once there)

#: The shape, as the search logged it ("blend search: corner 0: ... shape G2Shape(...)"), tolerance 0.01 m.
SHAPE = dict(entry=0.09999989999999997, exit=0.12153108143347184, shape_entry=0.723292583974,
             shape_exit=0.709767092412, deviation=0.009897454862369558, offset_entry=0.0,
             offset_exit=0.00989216166658531, run_entry=0.10961535725584, run_exit=0.12109836701168,
             slope_entry=0.0046037834154087276, slope_exit=0.004100886670062047, bend_entry=-0.16799775252891222,
             bend_exit=-1.9011257383790001, rise_entry=(0.0, 0.012547578284343644, -0.4578766551864755),
             rise_exit=(-5.755091346813448e-05, -2.385826089848314e-05, 0.0031260197376505308))


def main() -> None:
    from pathmotion.geometry.blends import G2Shape, with_shaped_g2_blends
    from pathmotion.planning.blend_search import duration_with, replace_settings
    from pathmotion.robot import load_robot
    from pathmotion.study.atlas import _settings, _task

    robot, task = load_robot("irb140"), _task(TURN)
    shape = {0: G2Shape(**SHAPE)}
    base = _settings(verify=False, baselines=False)
    for points in (300, 600, 1200, 2400, 4800):
        fixed = replace_settings(base, grid_points=points)
        print(f"grid {points:5d} points: {duration_with(robot, task, shape, fixed):.5f} s")
    print(f"adaptive grid:      {duration_with(robot, task, shape, base):.5f} s")
    path = with_shaped_g2_blends(task, shape)
    print("pieces:", ", ".join(f"{s.kind} {1e3 * s.length:.2f} mm" for s in path.segments))
    theta = np.linspace(0.0, path.length, 200_001)
    curvature = np.linalg.norm(path.evaluate(theta)[2], axis=1)
    print(f"curvature peak {curvature.max():.0f} 1/m at {1e3 * theta[np.argmax(curvature)]:.2f} mm of "
          f"{1e3 * path.length:.1f} mm")


if __name__ == "__main__":
    main()
