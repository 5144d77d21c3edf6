"""The output schema: every key of summary.json, sweep rows and demo tables, listed once.

Each :class:`Key` says what the value is (``label``), the unit it is shown in (``unit``) and the
factor from the stored SI value to that unit (``scale``: 1e3 shows metres as mm). Tables, the
report, the study's score and the CSV writers name keys through the constants below, never through
string literals of their own. Each limit's names (its scenario keys, summary keys, report labels) are one
row of :data:`LIMITS`, which its class in ``planning/limits`` reads.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Key:
    """One output quantity: ``key`` as stored (SI units), ``label`` (long), ``unit`` and ``scale``
    for display (shown value = stored value x scale), ``short``: the label in narrow tables."""

    key: str
    label: str
    unit: str = ""
    scale: float = 1.0
    short: str = ""

    @property
    def heading(self) -> str:
        """``short`` (or ``label``) with the unit in brackets, e.g. 'path dev [mm]'."""
        text = self.short or self.label
        return f"{text} [{self.unit}]" if self.unit and self.unit != "-" else text


def _k(key, label, unit="", scale=1.0, short="") -> Key:
    return Key(key, label, unit, scale, short)


# ------------------------------------------------------------------------------------- plan
SCENARIO = _k("scenario", "scenario", short="scenario")
ROBOT = _k("robot", "robot")
PATH_LENGTH = _k("path_length", "path length (θ range)", "m")
PATH_KIND = _k("path_kind", "path kind")
DURATION = _k("duration_s", "time-optimal duration", "s")
SOLVE_TIME = _k("solve_time_s", "planner solve time", "s")
GRID_POINTS = _k("grid_points", "planner grid points")
DURATION_ERROR_ESTIMATE = _k("duration_error_estimate", "estimated discretization error of the duration (adaptive "
                             "grid, or jerk / torque-rate plans' nested coarse grids; null on a fixed grid "
                             "otherwise)", "ms", 1e3, short="duration error est.")
TORQUE_RESERVE = _k("torque_reserve", "torque reserve kept free for feedback (fraction of each torque limit)", "-")


@dataclass(frozen=True)
class LimitNames:
    """Every name of one limit, in one row: ``name`` (ratios, limits.json, phase_plane.csv columns); ``keys``:
    its ``[limits]`` keys (PlanSettings(limits=...) takes the same) -> the LimitChoice field each sets
    ("on", "scale", "value"); ``ratio``: summary.json's key of its largest |value| / limit; ``settings``:
    its other summary.json keys; ``unit`` of its enforced values; ``label``: its row in the report;
    ``curve``: the phase plane's legend of its own maximum-velocity curve ("" for the third-order limits,
    which have none); ``steady``: the legend of a third-order limit's steady-speed curve; ``color`` of
    both curves."""

    name: str
    keys: dict
    ratio: Key
    unit: str
    label: str
    curve: str = ""
    steady: str = ""
    color: str = ""
    settings: tuple[Key, ...] = ()


#: The limits' names, by limit name (the planner's classes in planning/limits/ read theirs from here).
LIMITS = {row.name: row for row in (
    LimitNames("velocity", {"use_velocity": "on", "velocity_scale": "scale"},
               _k("max_velocity_ratio", "largest joint velocity / limit", "-"), "rad/s", "velocity",
               "joint velocity limit", color="#9467bd"),
    LimitNames("acceleration", {"use_acceleration": "on", "acceleration_scale": "scale"},
               _k("max_acceleration_ratio", "largest joint acceleration / limit", "-"), "rad/s²", "acceleration",
               "joint acceleration limit", color="#ff7f0e"),
    LimitNames("torque", {"use_torque": "on", "torque_scale": "scale", "torque_reserve": "value"},
               _k("max_torque_ratio", "largest joint torque / limit", "-"), "N m", "torque", "joint torque limit",
               color="#8c564b", settings=(TORQUE_RESERVE,)),
    LimitNames("tcp_speed", {"tcp_speed": "value"}, _k("max_tcp_speed_ratio", "largest TCP speed / limit", "-"),
               "m/s", "TCP speed", "TCP speed limit", color="#bcbd22"),
    LimitNames("torque_speed", {"torque_speed": "value"},
               _k("max_torque_speed_ratio", "largest joint torque / torque-speed envelope", "-"),
               "knee / at top speed", "torque-speed envelope", "torque-speed envelope", color="#e377c2"),
    LimitNames("jerk", {"use_jerk": "on", "jerk_scale": "scale", "jerk": "value"},
               _k("max_jerk_ratio", "largest joint jerk / limit", "-"), "rad/s³", "jerk",
               steady="jerk limit at constant speed", color="#111111"),
    LimitNames("torque_rate", {"use_torque_rate": "on", "torque_rate_scale": "scale", "torque_rate": "value"},
               _k("max_torque_rate_ratio", "largest joint torque rate / limit", "-"), "N m/s", "torque rate",
               steady="torque-rate limit at constant speed", color="#17becf"),
)}
MAX_VELOCITY_RATIO = LIMITS["velocity"].ratio
MAX_ACCELERATION_RATIO = LIMITS["acceleration"].ratio
MAX_PLAN_TORQUE_RATIO = LIMITS["torque"].ratio
MAX_TCP_SPEED_RATIO = LIMITS["tcp_speed"].ratio
MAX_TORQUE_SPEED_RATIO = LIMITS["torque_speed"].ratio
MAX_JERK_RATIO = LIMITS["jerk"].ratio
MAX_TORQUE_RATE_RATIO = LIMITS["torque_rate"].ratio
SECOND_ORDER_DURATION = _k("second_order_duration_s", "time-optimal duration without the jerk and torque-rate "
                           "limits", "s", short="without jerk / torque rate")
WORST_LIMIT = _k("worst_limit", "where the largest ratio is")
VERIFY_METHOD = _k("verify_method", "limit ratios from (certified interval bounds or dense resample)")
BASELINE_DURATION = _k("baseline_constant_speed_duration_s", "baseline: constant TCP speed duration", "s",
                       short="const. TCP speed")
FITTED_DURATION = _k("fitted_profile_duration_s", "baseline: fitted profile duration", "s")
BASELINE_ERROR = _k("baseline_constant_speed_error", "baseline: constant TCP speed error")
CONNECTIONS = _k("connections", "connections taken as")
VELOCITY_JUMPS = _k("velocity_jumps", "velocity jumps (θ intervals)")
KINKS = _k("kinks_theta", "sharp corners (θ)")
BLEND_MAX_DEVIATION = _k("blend_max_deviation_m", "blend: largest distance from the sharp path", "mm", 1e3)
MIN_SINGULAR_VALUE = _k("min_singular_value", "smallest singular value of the Jacobian", "-")
WRIST_CROSSINGS = _k("wrist_singularity_crossings", "wrist passages near q5 = 0: crossed on the smooth branch or "
                     "passed, each with its speed cost (velocity-limited path speed in it vs at its edges, planned "
                     "speed)")
RAPID_ESTIMATE = _k("rapid_estimate_s", "RAPID program at its programmed speeds (estimate)", "s")
FAILURES = _k("failures", "why the plan must not be run, each {kind, message, where} (empty: it may)")
EXPORT_NOTES = _k("export_notes", "notes at the top of the exports (ROS 2, EGM, RAPID)")
JOINT_RANGE_MARGIN = _k("joint_range_margin_rad", "smallest joint-range margin", "rad")
TORQUE_RESERVE_SEARCH = _k("torque_reserve_search", 'torque_reserve = "auto": the reserves tried, in order, with '
                           "their verdicts (tracks / fails / infeasible) and closed-loop figures")

# ------------------------------------------------------------------------------- simulation
CONTROLLER = _k("controller", "controller")
PLANT = _k("plant", "plant (simulator)")
SAMPLE_TIME = _k("sample_time_s", "controller sample time", "ms", 1e3)
SUBSTEPS = _k("substeps", "plant sub-steps per controller sample", "-")
SUBSTEPS_NOTE = _k("substeps_note", "why the plant took more sub-steps than simulate.substeps")
PLANNED_DURATION = _k("planned_duration_s", "planned duration", "s", short="planned")
CYCLE_TIME = _k("cycle_time_s", "cycle time, closed loop (the TCP at the end within the path tolerance)", "s",
                short="cycle time")
SETTLE_TIME = _k("settle_time_s", "settle time (the TCP within the path tolerance of the end for good)", "s")
MAX_JOINT_DEVIATION = _k("max_joint_deviation_rad", "largest joint tracking error", "mrad", 1e3, short="joint dev")
RMS_JOINT_DEVIATION = _k("rms_joint_deviation_rad", "RMS joint tracking error", "mrad", 1e3)
PATH_TOLERANCE = _k("path_tolerance_m", "path tolerance of the verdict", "mm", 1e3)
PATH_ACCURACY = _k("path_accuracy_m", "path accuracy: largest TCP distance from the planned path", "mm", 1e3,
                   short="path accuracy")
PATH_TOLERANCE_DEG = _k("path_tolerance_deg", "orientation tolerance of the verdict", "deg")
PATH_ACCURACY_DEG = _k("path_accuracy_deg", "orientation path accuracy: largest tool angle from the planned orientation",
                       "deg", short="orientation accuracy")
CORNERING_DEVIATION = _k("cornering_deviation_m", "largest TCP distance from the sharp path, per corner", "mm", 1e3)
MAX_SHARP_DEVIATION = _k("max_sharp_deviation_m", "largest TCP distance from the original sharp path", "mm", 1e3,
                         short="max dev. from sharp path")
MAX_TORQUE_RATIO = _k("max_torque_ratio", "largest applied torque / limit", "-")
MAX_COMMANDED_TORQUE_RATIO = _k("max_commanded_torque_ratio", "largest commanded torque / limit (before saturation)",
                                "-")
SATURATION_TIME = _k("saturation_time_s", "time with a torque saturated", "s")
TRACKING_OK = _k("tracking_ok", "tracking ok")
FIGURES_COVER = _k("figures_cover_t_s", "the time the figures cover [start, end]", "s")
COVERAGE_NOTE = _k("coverage_note", "why the figures cover less than the whole motion")
FAILURE = _k("failure", "failure")
IDENTIFIED_PAYLOAD = _k("identified_payload_kg", "payload the controller identified (negative: the model's is too heavy)",
                        "kg", short="identified payload")
IDENTIFIED_PAYLOAD_STD = _k("identified_payload_std_kg", "standard error of the identified payload mass", "kg")
IDENTIFIED_PAYLOAD_NOTE = _k("identified_payload_note", "why no payload mass is reported (not significant)")
IDENTIFIED_PAYLOAD_COM = _k("identified_payload_com_m", "identified payload's centre of mass, flange frame", "mm", 1e3)
IDENTIFIED_VISCOUS = _k("identified_viscous_friction", "identified viscous friction per joint", "N m s/rad")
IDENTIFIED_COULOMB = _k("identified_coulomb_friction", "identified Coulomb friction per joint", "N m")
EVENTS = _k("events", "re-timing events: time, kind, re-timing time [ms], reaction time [s], stop distance")

#: The closed loop's time under the name older tables use (read, never written).
LEGACY_SIMULATED_DURATION = _k("simulated_duration_s", "simulated duration (older tables)", "s", short="simulated")

# ------------------------------------------------------------------------------------ study
MEAN_SHARP_DEVIATION = _k("mean_sharp_deviation_m", "mean TCP distance from the original sharp path", "mm", 1e3,
                           short="mean dev. from sharp path")
MEAN_PATH_DEVIATION = _k("mean_path_deviation_m", "mean TCP distance from the planned path", "mm", 1e3)
FAILURE_REASON = _k("failure_reason", "failure reason", short="failure")
ERROR = _k("error", "error")
WALL_TIME = _k("wall_time_s", "wall time", "s")

#: Headline keys of a plan's summary.json, in display order.
PLAN = (DURATION, SECOND_ORDER_DURATION, FITTED_DURATION, BASELINE_DURATION, MAX_VELOCITY_RATIO,
        MAX_ACCELERATION_RATIO, MAX_PLAN_TORQUE_RATIO, MAX_TCP_SPEED_RATIO, MAX_TORQUE_SPEED_RATIO, MAX_JERK_RATIO,
        MAX_TORQUE_RATE_RATIO, TORQUE_RESERVE, WORST_LIMIT, PATH_LENGTH, BLEND_MAX_DEVIATION,
        MIN_SINGULAR_VALUE, JOINT_RANGE_MARGIN, CONNECTIONS, GRID_POINTS, DURATION_ERROR_ESTIMATE, SOLVE_TIME)
#: Headline keys of a simulation's summary.json, in display order.
SIMULATION = (CONTROLLER, PLANT, SAMPLE_TIME, SUBSTEPS, PLANNED_DURATION, CYCLE_TIME, SETTLE_TIME, TRACKING_OK,
              PATH_TOLERANCE, PATH_ACCURACY, PATH_TOLERANCE_DEG, PATH_ACCURACY_DEG, MAX_SHARP_DEVIATION,
              CORNERING_DEVIATION, MAX_JOINT_DEVIATION, RMS_JOINT_DEVIATION, MAX_TORQUE_RATIO, MAX_COMMANDED_TORQUE_RATIO, SATURATION_TIME, IDENTIFIED_PAYLOAD)
#: Columns a sweep row holds after the parameters, in this order (then ``error``).
SWEEP_ROW = (CYCLE_TIME, PLANNED_DURATION, SETTLE_TIME, TRACKING_OK, FAILURE_REASON, MAX_SHARP_DEVIATION,
             MEAN_SHARP_DEVIATION, PATH_ACCURACY, MEAN_PATH_DEVIATION, BLEND_MAX_DEVIATION,
             MAX_JOINT_DEVIATION, RMS_JOINT_DEVIATION, MAX_TORQUE_RATIO, MAX_COMMANDED_TORQUE_RATIO, SATURATION_TIME,
             BASELINE_DURATION, CONTROLLER, SAMPLE_TIME)
#: The sweep table of the report, in column order.
SWEEP_TABLE = (CYCLE_TIME, PLANNED_DURATION, MAX_SHARP_DEVIATION, MEAN_SHARP_DEVIATION, PATH_ACCURACY, TRACKING_OK,
               FAILURE_REASON, ERROR)
#: The demo's comparison table (demo.csv and the terminal), in column order.
DEMO = (SCENARIO, PLANNED_DURATION, CYCLE_TIME, TRACKING_OK, MAX_JOINT_DEVIATION, PATH_ACCURACY,
        MAX_SHARP_DEVIATION, BASELINE_DURATION)


# ------------------------------------------------------------------------------- phase plane
#: phase_plane.csv, written with the plan: theta (the planner's grid) and theta_dot columns.
PHASE_PLANE_FILE = "phase_plane.csv"
#: One row per program move of an imported robot program (planning/program_moves.py).
MOVES_FILE = "moves.csv"
PHASE_THETA = "theta"
#: The plan's profile, the planner's curves (all limits together), the baselines.
PHASE_OPTIMAL = "theta_dot_optimal"
#: The plan's own profile beyond theta_dot, written when it has them (so that a plan folder is the plan):
#: a jerk-limited profile's theta_ddot at the grid points, and the dwell [s] at each grid point.
PHASE_OPTIMAL_DDOT = "theta_ddot_optimal"
PHASE_HOLDS = "hold_s"
PHASE_POINTWISE = "theta_dot_max_pointwise"
PHASE_CONTROLLABLE = "theta_dot_controllable"
PHASE_FITTED = "theta_dot_fitted"
PHASE_CONSTANT_SPEED = "theta_dot_constant_speed"
#: With jerk or torque-rate limits on: the optimum under the same limits without them.
PHASE_SECOND_ORDER = "theta_dot_second_order"
#: Each active limit's own maximum-velocity curve: this prefix + the limit's name ("torque", ...).
PHASE_LIMIT_PREFIX = "theta_dot_limit_"


def limit_curve_column(name: str) -> str:
    """phase_plane.csv column of one limit's maximum-velocity curve (e.g. "theta_dot_limit_torque")."""
    return PHASE_LIMIT_PREFIX + name


def limit_curve_names(columns) -> list[str]:
    """The limit names of the limit-curve columns among ``columns``, in their order."""
    return [c[len(PHASE_LIMIT_PREFIX):] for c in columns if c.startswith(PHASE_LIMIT_PREFIX)]


#: Each active third-order limit's steady-speed curve (the largest constant path speed within it; not a
#: bound on the motion): this prefix + the limit's name ("jerk", "torque_rate").
PHASE_STEADY_PREFIX = "theta_dot_steady_"


def steady_curve_column(name: str) -> str:
    """phase_plane.csv column of one third-order limit's steady-speed curve (e.g. "theta_dot_steady_jerk")."""
    return PHASE_STEADY_PREFIX + name


def steady_curve_names(columns) -> list[str]:
    """The limit names of the steady-speed columns among ``columns``, in their order."""
    return [c[len(PHASE_STEADY_PREFIX):] for c in columns if c.startswith(PHASE_STEADY_PREFIX)]


def keys(entries) -> tuple[str, ...]:
    """The stored key names of ``entries`` (Key objects)."""
    return tuple(e.key for e in entries)


def display(entries, short: bool = False) -> dict[str, tuple[str, str, float]]:
    """{key: (label, unit, scale)} of ``entries``, in their order (``short``: the short labels)."""
    return {e.key: ((e.short or e.label) if short else e.label, e.unit, e.scale) for e in entries}
