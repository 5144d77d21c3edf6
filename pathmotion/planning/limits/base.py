"""The limit interface: one class per limit, in the spirit of toppra's constraint classes.

A limit instance holds its effective values (the robot's limit times the user's scale, or a value
the user gave) and produces, at K path points:

* order 1 (velocity level): a bound on x = theta_dot^2, ``bound(points, scale)`` -> x_max (K,);
* order 2 (acceleration level): rows ``rows(points, scale, x_ref)`` -> (a, b, c, lo, hi), each (K, m),
  of the canonical form lo <= a u + b x + c <= hi with u = theta_ddot;
* order 3 (jerk level, e.g. a joint jerk limit, which needs Phi''' and theta_dddot): the planner's
  first-order discretization has no third-order term, so such a limit gives order-2 rows linearized
  conservatively around ``x_ref`` (the previous solve's x on the grid, None on the first solve). A
  limit whose bounds depend on the speed (a torque-speed envelope tau_max(qd)) does the same: its
  ``lo``/``hi`` are evaluated at ``x_ref`` so that they are inner (safe) bounds.

Every limit also gives what it enforces (``enforced``, for limits.json), its ratio |value| / limit on a time resample (``ratios``, (N, m)), the
summary key of its largest ratio, the keys that set it in a scenario's ``[limits]`` table and in
:class:`~pathmotion.planning.PlanSettings`, and accepts point-wise scale factors (K, m) (<= 1) that
the verify-and-tighten loop lowers where the continuous motion exceeds it between grid points.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, ClassVar, NamedTuple

import numpy as np

from ...errors import ScenarioError
from ...io.schema import LimitNames
from ...lift.joint_path import JointPath
from ...robot import Robot
from ..trajectory import Samples


class Rows(NamedTuple):
    """Canonical rows lo <= a u + b x + c <= hi at K points; each (K, m)."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


class Rows3(NamedTuple):
    """Third-order rows |sqrt(x) (a3 u' + a u + b x + c)| <= lim at K points, each (K, m): joint
    jerk has (Phi', 3 Phi'', Phi''', 0), torque rate (alpha, alpha' + 2 beta, beta', gamma')."""

    a3: np.ndarray
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    lim: np.ndarray


class RowForm(NamedTuple):
    """A limit's value on a grid interval as v = a u + b x + c (u = theta_ddot, x = theta_dot^2), for
    the certified row form (planning/certify.py): ``a``, ``b``, ``c`` are (right, left) pairs of (K, m)
    coefficients at the grid points, seen from the interval after / before each point (None for 0);
    the ratio is |v| / ``limit`` (m,), or sqrt(|v|) when ``squared`` (a speed limit, v = G x with
    G = (gain / limit)^2 and ``limit`` 1). ``knot_jumps`` (for a, b, c): the jump of the coefficient's
    slope at each of the path's spline knots on the grid (``ctx.knots``), right minus left, (k, m); None
    where it is continuous. A coefficient linear in Phi'' jumps there, with Phi'''."""

    a: "tuple[np.ndarray, np.ndarray] | None"
    b: "tuple[np.ndarray, np.ndarray] | None"
    c: "tuple[np.ndarray, np.ndarray] | None"
    limit: np.ndarray
    squared: bool = False
    knot_jumps: tuple = (None, None, None)


@dataclass(frozen=True)
class LimitChoice:
    """A user's choice for one limit: ``on`` (use it), ``scale`` (> 0, multiplies the robot's
    limit), ``value`` (a limit the user gives, e.g. a TCP speed [m/s]; None = not given)."""

    on: bool = True
    scale: float = 1.0
    value: float | tuple | None = None


class PathPoints:
    """Path data at the grid points theta (K,), seen from one side of each point: q, dq = Phi',
    ddq = Phi'' (K, n). Derived quantities (reduced dynamics, TCP gain, ...) are computed once and
    shared by every limit through :meth:`cached`. ``base``/``changed``: these points equal ``base``
    except at the indices ``changed`` (the left side of segment connections), so derived
    quantities are computed there only."""

    def __init__(self, robot: Robot, path: JointPath, theta, q, dq, ddq, base: "PathPoints | None" = None,
                 changed: np.ndarray | None = None, side: str = "right"):
        self.robot, self.path, self.theta, self.side = robot, path, theta, side
        self.q, self.dq, self.ddq = q, dq, ddq
        self._base, self._changed = base, changed
        self._cache: dict = {}

    def changed_from(self, other: "PathPoints") -> np.ndarray | None:
        """The indices where these points differ from ``other`` when they were built on it (its ``base``), else
        None (no relation known)."""
        return self._changed if self._base is other else None

    @property
    def dddq(self) -> np.ndarray:
        """Phi''' (K, n), exact (path.evaluate3), computed on first use."""
        if "dddq" not in self._cache:
            if self._base is None:
                value = self.path.evaluate3(self.theta, self.side)[3]
            else:
                value = self._base.dddq.copy()
                i = self._changed
                if i is not None and len(i):
                    value[i] = self.path.evaluate3(self.theta[i], self.side)[3]
            self._cache["dddq"] = np.atleast_2d(value)
        return self._cache["dddq"]

    def cached(self, key: str, compute: Callable[..., tuple], third: bool = False) -> tuple:
        """``compute(robot, q, dq, ddq)`` (with ``third``: ``compute(robot, q, dq, ddq, dddq)``) -> tuple of
        arrays with leading axis K, computed once per key; ``compute`` must act point by point."""
        if key not in self._cache:
            data = (self.q, self.dq, self.ddq) + ((self.dddq,) if third else ())
            if self._base is None:
                value = tuple(compute(self.robot, *data))
            else:
                value = tuple(v.copy() for v in self._base.cached(key, compute, third))
                i = self._changed
                if i is not None and len(i):
                    for v, w in zip(value, compute(self.robot, *(d[i] for d in data))):
                        v[i] = w
            self._cache[key] = value
        return self._cache[key]


class Limit:
    """Base class of a limit (see the module docstring). Subclasses set the class attributes and
    implement :meth:`from_robot`, :meth:`ratios`, :meth:`enforced` and one of :meth:`bound` (order 1) or
    :meth:`rows`."""

    #: Name: key in ratios and scale dicts, and the kind in messages ("torque").
    name: ClassVar[str]
    #: 1: bounds x = theta_dot^2; 2: rows in (theta_ddot, x); 3: involves theta_dddot (linearized rows).
    order: ClassVar[int]
    #: True: one column per joint (scale and ratios (K, n)); False: one column (e.g. the TCP).
    per_joint: ClassVar[bool] = True
    #: The verification needs joint torques on the resample.
    needs_torque: ClassVar[bool] = False
    #: Its names (io/schema.py's LIMITS row: keys, summary keys, report labels); None for a limit the table
    #: does not list (its summary key is then max_<name>_ratio).
    names: ClassVar[LimitNames | None] = None
    #: Its keys of a scenario's ``[limits]`` table, which PlanSettings(limits={...}) takes too -> the
    #: LimitChoice field each sets ("on", "scale", "value"): ``use_<name>`` switches, ``<name>_scale``
    #: scales, the bare name holds a value the user gives (``names.keys`` for a listed limit).
    keys: ClassVar[dict[str, str]]
    #: Unit of a user-given value, in messages.
    unit: ClassVar[str] = ""
    #: Rows depend on ``x_ref`` (a conservative linearization, e.g. a torque-speed envelope): the
    #: planner re-solves with x_ref = the previous solution until the duration settles.
    relinearize: ClassVar[bool] = False
    #: summary.json keys of :meth:`summary_values` (written as null when the limit is off).
    extra_summary_keys: ClassVar[tuple[str, ...]] = ()
    #: ``from_robot`` also receives every limit's choice (``choices={name: LimitChoice}``), for a
    #: limit defined relative to another one (the envelope scales the torque limit).
    uses_choices: ClassVar[bool] = False

    @classmethod
    def summary_key(cls) -> str:
        """summary.json key of the largest ratio, e.g. "max_torque_ratio"."""
        return cls.names.ratio.key if cls.names is not None else f"max_{cls.name}_ratio"

    @classmethod
    def key_for(cls, field: str) -> str:
        """Its ``[limits]`` key that sets the LimitChoice field ``field`` ("on", "scale", "value")."""
        return next(key for key, f in cls.keys.items() if f == field)

    @classmethod
    def default_choice(cls) -> LimitChoice:
        return LimitChoice()

    @classmethod
    def check_choice(cls, choice: LimitChoice) -> LimitChoice:
        """ScenarioError unless scale > 0 and value is None or > 0 (both finite)."""
        for key, field in cls.keys.items():
            v = getattr(choice, field)
            if field == "on" and not isinstance(v, (bool, np.bool_)):
                raise ScenarioError(f"limits.{key} must be true or false, got {v!r}")
            if field == "scale" and not (np.isfinite(v) and v > 0):
                raise ScenarioError(f"limits.{key} must be > 0, got {v}")
            if field == "value" and v is not None and not (np.isfinite(v) and v > 0):
                raise ScenarioError(f"limits.{key} must be > 0 {cls.unit} or None, got {v}")
        return choice

    @classmethod
    def from_robot(cls, robot: Robot, choice: LimitChoice) -> "Limit | None":
        """The effective limit for ``robot`` under ``choice``; None when it is off."""
        raise NotImplementedError

    def columns(self, n: int) -> int:
        """Columns m of the scale and ratio arrays for an n-joint arm."""
        return n if self.per_joint else 1

    def bound(self, points: PathPoints, scale: np.ndarray) -> np.ndarray | None:
        """Order 1: x_max (K,) (inf where unbounded) with the limit scaled by ``scale`` (K, m)."""
        return None

    def rows(self, points: PathPoints, scale: np.ndarray, x_ref: np.ndarray | None = None) -> Rows | None:
        """Order 2 and 3: canonical rows with the limit scaled by ``scale`` (K, m)."""
        return None

    def rows3(self, points: PathPoints, scale: np.ndarray) -> "Rows3 | None":
        """Order 3: rows |sqrt(x) (a3 u' + a u + b x + c)| <= lim, u' = d theta_ddot / d theta."""
        return None

    def enforced(self) -> "list[float] | float | dict":
        """What this limit enforces, JSON-ready in SI units (limits.json's "enforced"): a per-joint list,
        one number, or a dict of them. Every limit implements it."""
        raise NotImplementedError(f"limit {self.name!r} ({type(self).__name__}) does not implement enforced(); "
                                  "give it one (planning/limits/base.py) so that limits.json lists it")

    def summary_values(self) -> dict:
        """Extra summary.json entries of this limit's settings (e.g. {"torque_reserve": 0.2})."""
        return {}

    def check(self, points: PathPoints, joint_names: tuple[str, ...]) -> None:
        """InfeasibleError when no motion can meet the limit (e.g. gravity beyond a torque limit)."""

    def ratios(self, samples: Samples, robot: Robot) -> np.ndarray:
        """|value| / limit (N, m) on a time resample."""
        raise NotImplementedError

    def certify_row_form(self, ctx) -> "RowForm | None":
        """This limit's value in the row form of planning/certify.py (|a u + b x + c| / limit on every grid
        interval of the profile in ``ctx``, a CertifyContext), or None (the default): the sampled form
        (:meth:`ratios` at a few points per interval plus the interpolation remainder) on every interval.
        certify.certify bounds every limit's row form in one kernel call and samples where it does not
        hold or exceeds its refinement threshold, for all limits at once."""
        return None

    def column_name(self, j: int, joint_names: tuple[str, ...] | None) -> str:
        """What column j is, in messages."""
        return joint_names[j] if joint_names else f"joint {j + 1}"


def safe_ratio_bound(limit_sq: np.ndarray, gain: np.ndarray) -> np.ndarray:
    """limit_sq / gain^2 where gain != 0, inf elsewhere (the x bound of |gain| theta_dot <= limit)."""
    nz = gain != 0.0
    with np.errstate(divide="ignore"):
        return np.where(nz, limit_sq / np.where(nz, gain**2, 1.0), np.inf)
