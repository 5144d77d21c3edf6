"""The compiled sizing of a G2 blend between two lines (geometry/blend_sizing.py) against the Python sizing
(blends._largest_between over _BlendPieces' builds): the same shape, float for float, for one quintic and racing
lines (offsets, slopes, bends, rises) at the atlas' corners; free ends are sized in Python."""

import numpy as np
import pytest

from pathmotion.geometry import blends
from pathmotion.geometry.blends import g2_shape_for_tolerance
from pathmotion.study.atlas import _task, corner_points


def _python_sizing(monkeypatch, *args, **kw):
    with monkeypatch.context() as m:
        m.setattr(blends, "_compiled_sizing", lambda *a: None)
        return _shape_or_error(*args, **kw)


def _shape_or_error(*args, **kw):
    try:
        return g2_shape_for_tolerance(*args, **kw)
    except Exception as exc:  # the same error either way (e.g. runs that leave the quintic no room)
        return type(exc), str(exc)


@pytest.mark.parametrize("angle", [30, 90, 150])
def test_the_compiled_sizing_is_the_python_sizing(monkeypatch, angle):
    path = _task(corner_points(angle))
    rng = np.random.default_rng(angle)
    for tol in (1e-4, 1e-3, 1e-2):
        unit = np.sqrt(tol * 0.64)
        for _ in range(12):
            balance, shape_entry, shape_exit = rng.uniform(0.2, 0.8), rng.uniform(0.25, 1.0), rng.uniform(0.25, 1.0)
            kw = {}
            if rng.uniform() < 0.8:
                kw = dict(offsets=tuple(rng.uniform(0.0, 0.999, 2) * tol * (rng.uniform(size=2) < 0.8)),
                          runs=tuple(rng.uniform(0.3, 2.0, 2) * unit))
                if rng.uniform() < 0.5:
                    kw.update(slopes=tuple(rng.uniform(-0.05, 0.05, 2)), bends=tuple(rng.uniform(-3.0, 3.0, 2)))
                if rng.uniform() < 0.3:
                    kw.update(rises=tuple((rng.uniform(-0.9, 0.9) * tol, rng.uniform(-0.05, 0.05), 0.0)
                                          for _ in range(2)))
            args = (path, 0, tol, balance, shape_entry, shape_exit)
            assert _shape_or_error(*args, **kw) == _python_sizing(monkeypatch, *args, **kw)


def test_free_ends_keep_the_python_sizing():
    path = _task(corner_points(60))
    A, B = path.segments
    from pathmotion.geometry.blends import _BlendPieces, _corner

    c = _corner(path, 0, ("corner",), "test")
    free = _BlendPieces(A, B, 0.6, 0.6, (5e-3, 5e-3), (0.05, 0.05), "test", (0.0, 0.0), (0.0, 0.0),
                        ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), (1e-3, 1e-3, 0.0, 0.0), None)
    assert blends._compiled_sizing(c, free, 0.6, 0.6) is None
    joined = _BlendPieces(A, B, 0.6, 0.6, (5e-3, 5e-3), (0.05, 0.05), "test", (0.0, 0.0), (0.0, 0.0),
                          ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    assert blends._compiled_sizing(c, joined, 0.6, 0.6) is not None
