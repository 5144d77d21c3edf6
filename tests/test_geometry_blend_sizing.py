"""The compiled sizing of a G2 blend between two lines (geometry/blend_sizing.py) against the Python sizing
(blends._largest_between over _BlendPieces' builds): the same shape, float for float, for one quintic and racing
lines (offsets, slopes, bends, rises) at the atlas' corners, with departures and arrivals too."""

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


@pytest.mark.parametrize("angle", [30, 90, 150])
def test_the_compiled_sizing_of_free_ends_is_the_python_sizing(monkeypatch, angle):
    """Departures and arrivals (the piece's run follows the corner quintic's size): the same shape or the same
    error (a run with no room) as the Python sizing, and the compiled sizing does run there."""
    path = _task(corner_points(angle))
    rng = np.random.default_rng(1000 + angle)
    compiled, sizing, outcomes = [], blends._compiled_sizing, []

    def recorded(*a):
        compiled.append(sizing(*a))
        return compiled[-1]

    with monkeypatch.context() as m:
        m.setattr(blends, "_compiled_sizing", recorded)
        for tol in (1e-4, 1e-3, 1e-2):
            unit = np.sqrt(tol * 0.64)
            for _ in range(12):
                balance, shape_entry, shape_exit = rng.uniform(0.2, 0.8), rng.uniform(0.25, 1.0), rng.uniform(0.25, 1.0)
                ends = [None, None]
                for side in rng.permutation(2)[:rng.integers(1, 3)]:
                    ends[side] = tuple(rng.uniform(-0.9, 0.9, 4) * tol)
                kw = dict(offsets=tuple(rng.uniform(0.1, 0.999, 2) * tol), runs=tuple(rng.uniform(0.3, 2.0, 2) * unit),
                          departure=ends[0], arrival=ends[1])
                if rng.uniform() < 0.5:
                    kw.update(slopes=tuple(rng.uniform(-0.05, 0.05, 2)), bends=tuple(rng.uniform(-3.0, 3.0, 2)))
                if rng.uniform() < 0.5:
                    kw.update(rises=tuple((rng.uniform(-0.9, 0.9) * tol, rng.uniform(-0.05, 0.05),
                                           rng.uniform(-3.0, 3.0)) for _ in range(2)))
                args = (path, 0, tol, balance, shape_entry, shape_exit)
                shape = _shape_or_error(*args, **kw)
                assert shape == _python_sizing(monkeypatch, *args, **kw)
                outcomes.append(isinstance(shape, tuple))
    assert compiled and all(c is not None for c in compiled)
    assert not all(outcomes)  # shapes sized, not only errors


def test_the_compiled_pieces_of_free_ends_are_the_python_pieces():
    """blend_sizing.build's pieces with a departure and / or an arrival, float for float those of _BlendPieces (the
    sizing's bound can hide a wrong piece that stays within the tolerance)."""
    from pathmotion.geometry import blend_sizing
    from pathmotion.geometry.blends import _BlendPieces, _corner

    rng = np.random.default_rng(7)
    for angle in (30, 90, 150):
        path = _task(corner_points(angle))
        c = _corner(path, 0, ("corner",), "test")
        for _ in range(20):
            tol = 10.0 ** rng.uniform(-4, -2)
            ends = [tuple(rng.uniform(-0.9, 0.9, 4) * tol) if rng.uniform() < 0.7 else None for _ in range(2)]
            sa, sb = rng.uniform(0.25, 1.0, 2)
            rises = tuple((rng.uniform(-0.9, 0.9) * tol, rng.uniform(-0.05, 0.05), rng.uniform(-3.0, 3.0))
                          for _ in range(2))
            pieces_at = _BlendPieces(c.A, c.B, sa, sb, tuple(rng.uniform(0.1, 0.999, 2) * tol),
                                     tuple(rng.uniform(0.3, 2.0, 2) * np.sqrt(tol)), "test",
                                     tuple(rng.uniform(-0.05, 0.05, 2)), tuple(rng.uniform(-3.0, 3.0, 2)), rises,
                                     *ends)
            args = blends._compiled_sizing(c, pieces_at, sa, sb)[:13]  # lines ... axes
            balance, size = rng.uniform(0.2, 0.8), rng.uniform(0.1, 1.5) * np.sqrt(tol)
            out = np.zeros((3, 6, 3))
            n = blend_sizing.build(out, size, balance, *args)
            try:
                expected = pieces_at(balance * size, (1 - balance) * size)[0]
            except Exception:
                assert n == -1
                continue
            assert n == len(expected) and np.array_equal(out[:n], np.array(expected))
