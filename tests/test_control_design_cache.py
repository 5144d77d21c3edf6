"""The on-disk cache of the path table and the orbital design: a hit equals a fresh build, any input change
misses, a corrupt or foreign entry is rebuilt (never used), PATHMOTION_CACHE_DIR=off writes nothing."""

import numpy as np
import pytest

from pathmotion.control import OrbitalDesign, OrbitalGains, PathTable
from pathmotion.control import design_cache as dc
from pathmotion.lift.joint_path import SplineJointPath
from pathmotion.planning.profile import Profile

WAYPOINTS = np.array([[0.0, 0.0, 0.0, 0.0, 0.5, 0.0],
                      [0.5, 0.3, -0.2, 0.4, 0.8, 0.6],
                      [1.0, 0.1, 0.2, -0.2, 0.4, 1.2]])


def trapezoid(v=0.9, a=2.0):
    ta = v * v / (2 * a)
    return Profile(np.array([0.0, ta, 1 - ta, 1.0]), np.array([0.0, v * v, v * v, 0.0]))


def same(a: OrbitalDesign, b: OrbitalDesign) -> bool:
    return (np.array_equal(a.table.grid, b.table.grid) and np.array_equal(a.table.coeffs, b.table.coeffs)
            and np.array_equal(a.gain, b.gain) and np.array_equal(a.riccati, b.riccati) and a.zones == b.zones
            and a.basis == b.basis)


@pytest.fixture
def path():
    return SplineJointPath.from_waypoints(WAYPOINTS)


def test_a_hit_equals_a_fresh_build(tmp_path, path):
    fresh = OrbitalDesign.build(PathTable.from_path(path, 401), trapezoid(), OrbitalGains())
    first = dc.cached_design(path, trapezoid(), OrbitalGains(), points=401, folder=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 2  # table and design
    hit = dc.cached_design(path, trapezoid(), OrbitalGains(), points=401, folder=tmp_path)
    assert same(first, fresh) and same(hit, fresh)


def test_every_input_changes_the_key(tmp_path, path):
    t0 = dc.table_key(path, 401)
    other_path = SplineJointPath.from_waypoints(WAYPOINTS + np.array([0, 0, 0, 0, 0, 1e-6]))
    assert dc.table_key(other_path, 401) != t0 and dc.table_key(path, 402) != t0
    d0 = dc.design_key(t0, trapezoid(), OrbitalGains(), None, 0)
    assert len({d0, dc.design_key(t0, trapezoid(0.8), OrbitalGains(), None, 0),
                dc.design_key(t0, trapezoid(), OrbitalGains(bandwidth=30.0), None, 0),
                dc.design_key(t0, trapezoid(), OrbitalGains(), 0.004, 0),
                dc.design_key(t0, trapezoid(), OrbitalGains(), 0.004, 1)}) == 5


def test_a_changed_default_changes_the_key(path, monkeypatch):
    before = dc.table_key(path, 401)
    monkeypatch.setattr(dc.defaults, "RICCATI_KNOT_TIME", 1e-3)
    assert dc.table_key(path, 401) != before


@pytest.mark.parametrize("damage", ["truncate", "garbage", "nan", "foreign"])
def test_a_damaged_entry_is_rebuilt(tmp_path, path, damage, caplog):
    fresh = dc.cached_design(path, trapezoid(), OrbitalGains(), points=401, folder=tmp_path)
    entry = next(tmp_path.glob("design-*.npz"))
    if damage == "truncate":
        entry.write_bytes(entry.read_bytes()[:200])
    elif damage == "garbage":
        entry.write_bytes(b"not an npz file")
    else:
        with np.load(entry) as z:
            data = {k: z[k] for k in z.files}
        if damage == "nan":
            data["gain"][5, 0, 0] = np.nan
        else:
            data["key"] = np.array("0" * 64)
        np.savez(entry, **data)
    again = dc.cached_design(path, trapezoid(), OrbitalGains(), points=401, folder=tmp_path)
    assert same(again, fresh)
    assert "ignoring the controller cache entry" in caplog.text
    third = dc.cached_design(path, trapezoid(), OrbitalGains(), points=401, folder=tmp_path)  # rewritten: a hit
    assert same(third, fresh)


def test_off_writes_nothing(tmp_path, monkeypatch, path):
    monkeypatch.setenv(dc.ENV, "off")
    assert dc.cache_dir() is None
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    dc.cached_table(path, 101)
    assert not any(tmp_path.rglob("*.npz"))


def test_the_folder_follows_the_environment(tmp_path, monkeypatch):
    monkeypatch.delenv(dc.ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert dc.cache_dir() == tmp_path / "pathmotion"
    monkeypatch.setenv(dc.ENV, str(tmp_path / "x"))
    assert dc.cache_dir() == tmp_path / "x"
