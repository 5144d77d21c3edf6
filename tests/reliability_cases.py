"""The catalogue of bad inputs: one entry per case, grouped in classes, each with the error it
must raise and words its message must hold (what, where, what to change). docs/bad-inputs.md lists the
same ids; tests/test_reliability_inputs.py runs every case through the API and the command line."""

from __future__ import annotations

from dataclasses import dataclass, field

from pathmotion.errors import (InfeasibleError, PathError, PathmotionError, RobotModelError, ScenarioError,
                               UnreachableError)

#: A valid joint-space scenario on the IRB140 (coarse grid: fast).
JOINT = """name = "joint"
[path]
type = "joint"
waypoints = [[0, 0, 0, 0, 0.5, 0], [0.3, 0.2, -0.2, 0.3, 0.8, 0.5], [0.5, 0.1, 0.0, 0.0, 0.6, 1.0]]
[plan]
grid_points = 60
"""

#: A valid task-space scenario: a 0.2 m line, tool down, in front of the IRB140.
LINE = """name = "line"
[path]
type = "task"
[[path.segments]]
type = "line"
start = [0.5, -0.1, 0.5]
end = [0.5, 0.1, 0.5]
[plan]
grid_points = 60
"""

SEG0 = 'type = "line"\nstart = [0.5, -0.1, 0.5]\nend = [0.5, 0.1, 0.5]'


def _circle(body: str) -> str:
    return LINE.replace(SEG0, 'type = "circle"\n' + body)


def _then(extra: str) -> str:
    """LINE with more segments/blends after the first segment (TOML: before [plan])."""
    return LINE.replace("[plan]", extra + "\n[plan]")


def _corner(blend: str, end: str = "[0.6, 0.1, 0.5]") -> str:
    return _then(f'[[path.segments]]\ntype = "line"\nend = {end}\n[[path.blends]]\ncorner = 1\n{blend}')


def _square(corner: str, radius: str = "0.02") -> str:
    """A closed 0.2 m x 0.1 m rectangle (4 lines) with one circle blend at ``corner``."""
    sides = "".join(f'[[path.segments]]\ntype = "line"\nend = {e}\n'
                    for e in ("[0.6, 0.1, 0.5]", "[0.6, -0.1, 0.5]", "[0.5, -0.1, 0.5]"))
    return _then(sides + f'[[path.blends]]\ncorner = {corner}\ntype = "circle"\nradius = {radius}')


def _plan(extra: str) -> str:
    return JOINT + extra + "\n"


def _limits(extra: str) -> str:
    return JOINT + "[limits]\n" + extra + "\n"


# A 2-joint planar arm (links l0..l2); LIMIT is replaced by each joint's <limit> tag.
_LINK = ('<link name="{n}"><inertial><mass value="1"/><origin xyz="0 0 0.1"/><inertia ixx="0.01" iyy="0.01" '
         'izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>')
_JOINT = ('<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/><origin xyz="0 0 0.3"/>'
          '<axis xyz="0 1 0"/>LIMIT</joint>')
_LIMIT = '<limit lower="-3" upper="3" velocity="2" effort="50"/>'


def urdf(joints=(("j1", "l0", "l1"), ("j2", "l1", "l2")), limit: str = _LIMIT, extra: str = "") -> str:
    links = "".join(_LINK.format(n=f"l{i}") for i in range(3))
    js = "".join(_JOINT.format(n=n, p=p, c=c) for n, p, c in joints)
    return f'<robot name="arm">{links}{js}{extra}</robot>'.replace("LIMIT", limit)


ARM = """name = "arm"
[robot]
name = "arm.urdf"
[path]
type = "joint"
waypoints = [[0, 0], [0.5, 0.3]]
[plan]
grid_points = 60
"""

GOOD_LIMITS = "\n".join(
    f"[[joints]]\nname = 'joint_{j}'\nlower = -2.0\nupper = 2.0\nvelocity = 2.0\nacceleration = 10.0\ntorque = {t}"
    for j, t in zip(range(1, 7), (250, 350, 120, 20, 20, 10)))


@dataclass(frozen=True)
class Case:
    """id; klass: the class of bad input; text: scenario TOML; error: the PathmotionError subclass;
    says: regexes the one-line message must match; files: extra files next to the scenario;
    overrides: --set key paths; stage: where it fails: 'load' (reading and building), 'plan', 'write'
    (the plan's files) or 'simulate' (its settings)."""

    id: str
    klass: str
    text: str
    error: type
    says: tuple[str, ...]
    files: dict = field(default_factory=dict)
    overrides: dict = field(default_factory=dict)
    stage: str = "load"


CASES = (
    # --- the file itself
    Case("toml_syntax", "malformed file", "[[[", ScenarioError, ("not valid TOML", "line 1")),
    Case("toml_duplicate_table", "malformed file", JOINT + "[plan]\nstart = 'zero'\n", ScenarioError,
         ("not valid TOML", r"plan.*twice")),
    Case("empty_file", "malformed file", "", ScenarioError, (r"path: missing required key",)),
    Case("not_utf8", "malformed file", "\udcff", ScenarioError, ("cannot be read",)),
    # --- types
    Case("string_for_int", "wrongly typed value", _plan("").replace("grid_points = 60", 'grid_points = "60"'),
         ScenarioError, (r"plan\.grid_points", "valid integer", "'60'")),
    Case("bool_for_int", "wrongly typed value", JOINT + "[simulate]\nlaps = true\n", ScenarioError,
         (r"simulate\.laps", "valid integer")),
    Case("fraction_for_int", "wrongly typed value", JOINT.replace("grid_points = 60", "grid_points = 60.5"),
         ScenarioError, (r"plan\.grid_points", "integer")),
    Case("string_in_vector", "wrongly typed value", JOINT.replace("[[0, 0, 0,", '[["a", 0, 0,'), ScenarioError,
         (r"path\.waypoints\[0\]\[0\]", "number")),
    Case("table_for_number", "wrongly typed value", JOINT + "[limits]\ntcp_speed = {a = 1}\n", ScenarioError,
         (r"limits\.tcp_speed",)),
    Case("unknown_boundary_word", "wrongly typed value", _plan("").replace("grid_points = 60", "grid_points = 60\nstart = 'fast'"),
         ScenarioError, (r"plan\.start", "'zero' or 'max'")),
    # --- keys
    Case("unknown_key", "unknown key", JOINT + "sample_tme = 0.004\n", ScenarioError,
         (r"plan\.sample_tme", "unknown key", "did you mean 'sample_time'")),
    Case("unknown_table", "unknown key", JOINT + "[planner]\ngrid_points = 10\n", ScenarioError,
         (r"planner", "unknown key")),
    Case("missing_path", "missing key", 'name = "x"\n', ScenarioError, (r"path: missing required key",)),
    Case("missing_segment_key", "missing key", LINE.replace("end = [0.5, 0.1, 0.5]\n", ""), ScenarioError,
         (r"path\.segments\[0\]\.end", "missing")),
    Case("optimal_waypoint_blend_without_tolerance", "missing key",
         '[path]\ntype = "waypoints"\npoints = [[0.5, 0.0, 0.5], [0.6, 0.0, 0.5], [0.6, 0.1, 0.5]]\nblend = "optimal"\n',
         ScenarioError, (r"path", 'blend = "optimal" needs blend_tolerance > 0', "give one")),
    Case("unknown_gain", "unknown key", JOINT + "[simulate]\ngains = {bandwith = 5.0}\n", ScenarioError,
         ("simulate.gains", "bandwith", "allowed"), stage="simulate"),
    # --- units and counts
    Case("degrees_for_radians", "wrong units", JOINT.replace("[0.5, 0.1, 0.0, 0.0, 0.6, 1.0]", "[30, 10, 0, 0, 60, 90]"),
         ScenarioError, (r"path\.waypoints\[2\]", "joint_1 = 30 rad", "outside its range")),
    Case("milliseconds_for_seconds", "wrong units", JOINT + "[simulate]\nsample_time = 4\n", ScenarioError,
         (r"simulate\.sample_time", "0.1")),
    Case("millimetres_for_metres", "wrong units", _circle("center = [500, 0, 500]\nradius = 100.0"),
         ScenarioError, (r"path\.segments\[0\]\.center = \[500, 0, 500\]", "beyond IRB140's reach", r"mm\? the unit is m")),
    Case("waypoint_joint_count", "wrong joint count", JOINT.replace("[[0, 0, 0, 0, 0.5, 0]", "[[0, 0, 0, 0, 0.5]"),
         ScenarioError, (r"path\.waypoints\[0\] has 5 joint values", "6 joints", r"\[rad\]")),
    Case("limit_joint_count", "wrong joint count", _limits("velocity = [1, 1, 1, 1, 1]"), ScenarioError,
         (r"limits\.velocity has 5 values", "6 joints")),
    Case("start_configuration_count", "wrong joint count",
         LINE.replace('type = "task"', 'type = "task"\nstart_configuration = [0, 0, 0, 0, 0]'), PathError,
         ("start configuration has 5 values", "6 joints")),
    Case("vector_length", "wrong joint count", JOINT + "[robot.payload]\nmass = 1.0\ncom = [0, 0]\n", ScenarioError,
         (r"robot\.payload\.com\[2\]", "missing")),
    Case("limits_file_joint_count", "wrong joint count", JOINT + "[robot]\nlimits = 'lim.toml'\n", RobotModelError,
         ("lim.toml", r"1 \[\[joints\]\] entries", "6 joints"),
         files={"lim.toml": GOOD_LIMITS.split("\n[[joints]]")[0]}),
    # --- NaN and inf
    Case("nan_in_waypoint", "NaN or inf", JOINT.replace("[[0, 0, 0,", "[[nan, 0, 0,"), ScenarioError,
         (r"path\.waypoints\[0\]\[0\]", "finite")),
    Case("inf_limit", "NaN or inf", _limits("velocity = [inf, 1, 1, 1, 1, 1]"), ScenarioError,
         (r"limits\.velocity\[0\]", "finite")),
    Case("nan_point", "NaN or inf", LINE.replace("end = [0.5, 0.1, 0.5]", "end = [0.5, nan, 0.5]"), ScenarioError,
         (r"path\.segments\[0\]\.end\[1\]", "finite")),
    Case("nan_boundary_velocity", "NaN or inf", _plan("").replace("grid_points = 60", "grid_points = 60\nend = nan"),
         ScenarioError, (r"plan\.end",)),
    Case("inf_override", "NaN or inf", JOINT, ScenarioError, (r"plan\.sample_time", "finite"),
         overrides={"plan.sample_time": float("inf")}),
    Case("nan_in_limits_file", "NaN or inf", JOINT + "[robot]\nlimits = 'lim.toml'\n", RobotModelError,
         ("velocity", "NaN or inf"), files={"lim.toml": GOOD_LIMITS.replace("velocity = 2.0", "velocity = nan", 1)}),
    # --- reach
    Case("out_of_reach", "unreachable or singular path", LINE.replace("end = [0.5, 0.1, 0.5]", "end = [1.0, 0.1, 0.5]"),
         UnreachableError, (r"theta = \d", "segment 1", "out of reach")),
    Case("wrist_singular", "unreachable or singular path",
         LINE.replace("start = [0.5, -0.1, 0.5]", "start = [0.0, 0.0, 0.5]").replace("end = [0.5, 0.1, 0.5]", "end = [0.0, 0.0, 0.9]"),
         UnreachableError, ("theta = 0", "segment 1")),
    Case("wrist_flip", "unreachable or singular path",
         LINE.replace("[path]\n", "[path]\norientation = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]\n")
         .replace("start = [0.5, -0.1, 0.5]", "start = [0.515, -0.05, 0.713]")
         .replace("end = [0.5, 0.1, 0.5]", "end = [0.515, 0.05, 0.713]"),
         UnreachableError, (r"theta = 0\.0500 m", "segment 1", "wrist flip", r"rotating the tool frame by [+-]\d+ deg")),
    Case("joint_range_waypoint", "unreachable or singular path", JOINT.replace("[[0, 0, 0,", "[[0, 3, 0,"),
         ScenarioError, (r"path\.waypoints\[0\]", "joint_2", "outside its range")),
    # --- degenerate geometry
    Case("zero_length_line", "zero-length or degenerate segment", LINE.replace("end = [0.5, 0.1, 0.5]", "end = [0.5, -0.1, 0.5]"),
         PathError, (r"path\.segments\[0\]", "zero length", "distinct")),
    Case("zero_sweep_arc", "zero-length or degenerate segment",
         _then('[[path.segments]]\ntype = "arc"\ncenter = [0.5, 0.2, 0.5]\nsweep = 0.0'), PathError,
         (r"path\.segments\[1\]", "sweep 0", "non-zero sweep")),
    Case("arc_centre_on_start", "zero-length or degenerate segment",
         _then('[[path.segments]]\ntype = "arc"\ncenter = [0.5, 0.1, 0.5]\nsweep = 1.0'), PathError,
         (r"path\.segments\[1\]", "radius is 0 m")),
    Case("full_turn_radius_zero", "zero-length or degenerate segment", _circle("center = [0.5, 0, 0.5]\nradius = 0.0"),
         ScenarioError, (r"path\.segments\[0\]\.radius", "greater than 0")),
    Case("full_turn_radius_tiny", "zero-length or degenerate segment", _circle("center = [0.5, 0, 0.5]\nradius = 1e-12"),
         PathError, (r"path\.segments\[0\]", "radius")),
    Case("zero_normal", "zero-length or degenerate segment",
         _circle("center = [0.5, 0, 0.5]\nradius = 0.1\nnormal = [0, 0, 0]"), PathError,
         (r"path\.segments\[0\]", "zero length", "non-zero direction")),
    Case("repeated_waypoint", "zero-length or degenerate segment",
         JOINT.replace("[0.3, 0.2, -0.2, 0.3, 0.8, 0.5]", "[0, 0, 0, 0, 0.5, 0]"), PathError,
         ("waypoints 0 and 1 are identical", "remove")),
    Case("reversal_with_circle_blend", "180 degree reversal",
         _corner('type = "circle"\nradius = 0.01', end="[0.5, -0.1, 0.5]"), PathError,
         ("angle 180 deg", "reverses direction")),
    Case("reversal_with_g2_blend", "180 degree reversal",
         _corner('type = "g2"\ntolerance = 0.01', end="[0.5, -0.1, 0.5]"), PathError,
         ("angle 180 deg", "reverses direction", "sharp")),
    Case("not_a_rotation", "zero-length or degenerate segment",
         LINE.replace('type = "task"', 'type = "task"\norientation = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]'), PathError,
         ("not a proper rotation", "orthonormal")),
    # --- limits
    Case("zero_velocity_limit", "limit zero or of the wrong sign", _limits("velocity = [0, 1, 1, 1, 1, 1]"),
         RobotModelError, ("velocity of joint_1 is 0", "> 0")),
    Case("negative_torque_limit", "limit zero or of the wrong sign", _limits("torque = [-1, 1, 1, 1, 1, 1]"),
         RobotModelError, ("torque of joint_1 is -1", "> 0")),
    Case("zero_scale", "limit zero or of the wrong sign", _limits("acceleration_scale = 0"), ScenarioError,
         (r"limits\.acceleration_scale", "greater than 0")),
    Case("negative_limit_in_file", "limit zero or of the wrong sign", JOINT + "[robot]\nlimits = 'lim.toml'\n",
         RobotModelError, ("velocity of joint_1 is -2", "> 0"),
         files={"lim.toml": GOOD_LIMITS.replace("velocity = 2.0", "velocity = -2.0", 1)}),
    Case("lower_above_upper_in_file", "limit zero or of the wrong sign", JOINT + "[robot]\nlimits = 'lim.toml'\n",
         RobotModelError, ("joint_1 has lower 2.5 >= upper 2",),
         files={"lim.toml": GOOD_LIMITS.replace("lower = -2.0", "lower = 2.5", 1)}),
    Case("every_limit_off", "limit zero or of the wrong sign",
         _limits("use_velocity = false\nuse_acceleration = false\nuse_torque = false"), InfeasibleError,
         ("no active limit", "theta =", "use_"), stage="plan"),
    Case("gravity_above_torque_limit", "gravity torque above a limit", _limits("torque_scale = 0.01"),
         InfeasibleError, ("gravity torque of joint_2", "theta = 0", "torque limit"), stage="plan"),
    Case("payload_too_heavy", "gravity torque above a limit", JOINT + "[robot.payload]\nmass = 6.0\n"
         + "com = [0.0, 0.0, 0.6]\n", InfeasibleError, ("gravity torque of joint_", "payload"), stage="plan"),
    Case("payload_in_grams", "wrong units", JOINT + "[robot.payload]\nmass = 1000.0\n", ScenarioError,
         (r"robot\.payload\.mass = 1000 kg", "rated payload 6 kg", "the unit is kg")),
    Case("payload_inertia_not_psd", "limit zero or of the wrong sign",
         JOINT + "[robot.payload]\nmass = 1.0\ninertia = [[1, 2, 0], [0, 1, 0], [0, 0, 1]]\n", RobotModelError,
         ("inertia", "positive semi-definite")),
    # --- boundary conditions and modes
    Case("start_velocity_too_high", "impossible boundary velocity",
         _plan("").replace("grid_points = 60", "grid_points = 60\nstart = 1000.0"), InfeasibleError,
         ("start from theta_dot = 1000", "theta = 0", r"feasible start velocity range is \[0, "), stage="plan"),
    Case("end_velocity_too_high", "impossible boundary velocity",
         _plan("").replace("grid_points = 60", "grid_points = 60\nend = 1000.0"), InfeasibleError,
         ("end velocity theta_dot = 1000", "theta = 1", r"feasible range there is \[0, "), stage="plan"),
    Case("negative_boundary_velocity", "impossible boundary velocity",
         _plan("").replace("grid_points = 60", "grid_points = 60\nstart = -1.0"), ScenarioError, (r"plan\.start",)),
    Case("periodic_open_path", "impossible boundary velocity",
         _plan("").replace("grid_points = 60", "grid_points = 60\nperiodic = true"), ScenarioError,
         ("periodic planning needs a joint path that ends where it starts", "periodic = false"), stage="plan"),
    Case("jerk_with_max_connections", "impossible boundary velocity",
         _then('[[path.segments]]\ntype = "line"\nend = [0.6, 0.1, 0.5]').replace(
             "grid_points = 60", 'grid_points = 60\nconnections = "max"') + "[limits]\nuse_jerk = true\n",
         ScenarioError, ("jerk and torque-rate limits need a continuous profile", "connections = 'max'",
                         "use 'chain' or 'zero'"), stage="plan"),
    # --- blends
    Case("transition_too_large", "blend that does not fit", _corner('type = "circle"\nradius = 0.5'), PathError,
         ("radius 0.5 m does not fit", "connection 0", "theta = 0.2")),
    Case("g2_tolerance_too_large", "blend that does not fit", _corner('type = "g2"\ntolerance = 0.5'), PathError,
         ("tolerance 0.5 m is too large", "give a tolerance below")),
    Case("blend_at_smooth_joint", "blend that does not fit",
         _corner('type = "circle"\nradius = 0.01', end="[0.5, 0.2, 0.5]"), PathError,
         ("smooth", "only corner connections can be blended")),
    Case("blend_corner_missing", "blend that does not fit", _then('[[path.blends]]\ncorner = 3\ntype = "circle"\nradius = 0.01'),
         ScenarioError, (r"path\.blends\[0\]\.corner = 3", r"numbered 1\.\.")),
    Case("blend_without_size", "blend that does not fit", _then('[[path.blends]]\ncorner = 1\ntype = "g2"'),
         ScenarioError, (r"path\.blends\[0\]", "tolerance")),
    Case("several_turns", "blend that does not fit", _circle("center = [0.5, 0, 0.5]\nradius = 0.1\nturns = 2"),
         ScenarioError, (r"path\.segments\[0\]", "turns", "unknown key")),
    # --- robot files
    Case("urdf_loop", "URDF loop or missing joint", ARM, RobotModelError, ("arm", "closed loop", "remove"),
         files={"arm.urdf": urdf((("j1", "l0", "l1"), ("j2", "l1", "l2"), ("j3", "l2", "l0")))}),
    Case("urdf_missing_joint", "URDF loop or missing joint", ARM, RobotModelError,
         (r"links \['l0', 'l2'\] are not connected", "joint is missing"), files={"arm.urdf": urdf((("j1", "l0", "l1"),))}),
    Case("urdf_joint_to_missing_link", "URDF loop or missing joint", ARM, RobotModelError,
         ("joint 'j2' names child link 'l9'", "add the link"), files={"arm.urdf": urdf((("j1", "l0", "l1"), ("j2", "l1", "l9")))}),
    Case("urdf_two_parents", "URDF loop or missing joint", ARM, RobotModelError, ("child of two joints", "closed loop"),
         files={"arm.urdf": urdf((("j1", "l0", "l1"), ("j2", "l1", "l2"), ("j3", "l0", "l2")))}),
    Case("urdf_without_limits", "URDF loop or missing joint", ARM, RobotModelError,
         (r"joints \['j1', 'j2'\] have no <limit> tag", "limits file"), files={"arm.urdf": urdf(limit="")}),
    Case("urdf_zero_axis", "URDF loop or missing joint", ARM, RobotModelError, ("joint 'j1' has axis", "non-zero"),
         files={"arm.urdf": urdf().replace('xyz="0 1 0"', 'xyz="0 0 0"', 1)}),
    Case("urdf_negative_mass", "URDF loop or missing joint", ARM, RobotModelError, ("link 'l0' has mass '-1'", ">= 0"),
         files={"arm.urdf": urdf().replace('mass value="1"', 'mass value="-1"', 1)}),
    Case("urdf_not_xml", "URDF loop or missing joint", ARM, RobotModelError, ("not well-formed XML",),
         files={"arm.urdf": "<robot"}),
    Case("urdf_file_missing", "missing file", ARM, RobotModelError, ("neither a built-in robot", "URDF file")),
    Case("urdf_is_a_folder", "missing file", JOINT + "[robot]\nname = ''\n", RobotModelError,
         ("neither a built-in robot", "URDF file")),
    Case("limits_file_missing", "missing file", JOINT + "[robot]\nlimits = 'nope.toml'\n", RobotModelError,
         ("nope.toml does not exist",)),
    Case("urdf_parser_error", "URDF loop or missing joint", ARM, RobotModelError,
         ("URDF of arm cannot be parsed", r"upper value \(abc\) is not a valid float"),
         files={"arm.urdf": urdf(limit='<limit lower="-3" upper="abc" velocity="2" effort="50"/>')}),
    # --- special, oversized or badly named files (the one rule of pathmotion.io.files.read_input)
    Case("urdf_dev_zero", "special or oversized file", JOINT + "[robot]\nname = '/dev/zero'\n", RobotModelError,
         ("URDF file /dev/zero", "not a regular file")),
    Case("urdf_proc_file", "special or oversized file", JOINT + "[robot]\nname = '/proc/self/status'\n",
         RobotModelError, ("URDF file /proc/self/status", "not a regular file")),
    Case("limits_dev_urandom", "special or oversized file", JOINT + "[robot]\nlimits = '/dev/urandom'\n",
         RobotModelError, ("limits file /dev/urandom", "not a regular file")),
    Case("limits_is_a_folder", "special or oversized file", JOINT + "[robot]\nlimits = '.'\n", RobotModelError,
         ("limits file", "is a folder")),
    Case("urdf_nul_byte", "special or oversized file", JOINT + '[robot]\nname = "arm\\u0000.urdf"\n', RobotModelError,
         ("URDF file", "NUL byte")),
    Case("limits_name_too_long", "special or oversized file", JOINT + f"[robot]\nlimits = '{'x' * 300}.toml'\n",
         RobotModelError, ("limits file", "too long", "255 bytes")),
    Case("urdf_too_many_links", "special or oversized file", ARM, RobotModelError,
         ("1,001 <link> elements", "defaults.MAX_URDF_LINKS"),
         files={"arm.urdf": "<robot name='big'>" + "".join(f"<link name='l{i}'/>" for i in range(1001)) + "</robot>"}),
    # --- TOML nesting (checked before tomllib recurses)
    Case("toml_nesting_deep", "TOML nested too deeply", JOINT + "deep = " + "[" * 2000 + "]" * 2000 + "\n",
         ScenarioError, ("nested 2000 deep", "defaults.MAX_TOML_DEPTH")),
    Case("toml_dotted_key_deep", "TOML nested too deeply", JOINT + ".".join(["k"] * 20000) + " = 1\n",
         ScenarioError, ("dotted key of 20000 parts", "defaults.MAX_TOML_DEPTH")),
    Case("limits_file_nesting_deep", "TOML nested too deeply", JOINT + "[robot]\nlimits = 'lim.toml'\n",
         RobotModelError, ("lim.toml", "nested 100 deep"), files={"lim.toml": "x = " + "{a = " * 100 + "1" + "}" * 100}),
    # --- values without a range before
    Case("seed_negative", "value out of its range", JOINT + "[simulate.realism]\nseed = -1\n", ScenarioError,
         (r"simulate\.realism\.seed", "greater than or equal to 0")),
    Case("gain_huge", "value out of its range", JOINT + "[simulate]\ngains = {bandwidth = 1e308}\n", ScenarioError,
         (r"simulate\.gains\.bandwidth", "less than or equal to 10000")),
    Case("limits_sources_wrong_type", "value out of its range", JOINT + "[robot]\nlimits = 'lim.toml'\n",
         RobotModelError, ("joint 'joint_1' sources = \\[1, 2\\]", "give a table"),
         files={"lim.toml": GOOD_LIMITS.replace("torque = 250", "torque = 250\nsources = [1, 2]", 1)}),
    # --- overrides (--set)
    Case("override_bad_key_path", "bad override", JOINT, ScenarioError, ("bad key path 'plan\\[x\\]'",),
         overrides={"plan[x]": 3}),
    Case("override_missing_index", "bad override", JOINT, ScenarioError, (r"path\.waypoints\[7\]\[0\]", "no element 7"),
         overrides={"path.waypoints[7][0]": 1.0}),
    Case("override_into_number", "bad override", JOINT, ScenarioError, (r"plan\.grid_points\.x", "cannot set"),
         overrides={"plan.grid_points.x": 1}),
    # --- sizes
    Case("sample_time_far_too_small", "output far too large", _plan("").replace("grid_points = 60", "grid_points = 60\nsample_time = 1e-9"),
         PathmotionError, ("needs [0-9.]*e\\+08 samples", "raise the sample time"), stage="write"),
    # (the plan itself is solved; sampling its 3e8 s motion for the files is refused, before any file is written)
    Case("tcp_speed_far_too_small", "output far too large", _limits("tcp_speed = 1e-9"), PathmotionError,
         ("samples, more than", "tcp_speed"), stage="write"),
    # --- non-finite intermediate results: refused by name before they reach a limit or a file
    Case("payload_com_overflow", "non-finite intermediate result", JOINT + "[robot.payload]\nmass = 1.0\ncom = [1e308, 0, 0]\n",
         RobotModelError, (r"payload mass x \|com\|\^2 overflows", "robot.payload")),
    Case("payload_com_huge", "non-finite intermediate result", JOINT + "[robot.payload]\nmass = 1.0\ncom = [1e150, 0, 0]\n",
         ScenarioError, (r"robot\.payload\.com", "beyond IRB140's reach")),
    Case("payload_inertia_asymmetric", "non-finite intermediate result",
         JOINT + "[robot.payload]\nmass = 1.0\ninertia = [[1, 1e-3, 0], [0, 1, 0], [0, 0, 1]]\n", RobotModelError,
         ("asymmetric by 0.001", r"I\[i\]\[j\] = I\[j\]\[i\]")),
    Case("tool_translation_huge", "non-finite intermediate result", LINE + "[robot.tool]\ntranslation = [1e9, 0, 0]\n",
         UnreachableError, ("theta = 0", r"position error 1e\+09 m")),
    # --- closed polygons: corner N is the closing corner
    Case("closing_corner_number_too_high", "closed polygon", _square("5"), ScenarioError,
         (r"numbered 1\.\.4", "4 = the closing corner")),
    Case("closing_corner_blend_too_large", "closed polygon", _square("4", "0.3"), PathError,
         ("corner 4", "does not fit")),
)

CLASSES = tuple(dict.fromkeys(c.klass for c in CASES))
