"""Default values of every number that matters, defined once.

Scenario and robot files override these; code never repeats them as literals.
"""

from __future__ import annotations

#: Controller sample time of an ABB IRC5 controller [s].
SAMPLE_TIME = 0.004
#: Resample step used to verify that no limit is exceeded [s].
VERIFY_SAMPLE_TIME = 1e-4
#: Allowed relative excess over a limit on the verification resample [-].
LIMIT_TOLERANCE = 1e-3
#: The most of the order-2 limits a state the re-timer starts from (jerk limits) may take: a measured state, or a
#: plan's own, which reads up to about a percent above its limits between its grid points; the re-timed motion's
#: margin fades in from there over its first interval [-].
RETIME_STATE_SHARE_MAX = 1.02
#: Verify-and-tighten (planning/planner.py): an interval whose limit ratio exceeds 1 + this x the limit
#: tolerance is tightened; the certification (planning/certify.py) refines its bounds above the same
#: level (below it no refinement pays) [-].
TIGHTEN_TRIGGER = 0.5
#: Most samples one resample of a trajectory may hold (output files, verification): beyond it a
#: motion is far longer than any real one at that sample time (usually a limit set far too small) [-].
MAX_TRAJECTORY_SAMPLES = 2_000_000
#: Adaptive planner grid: requested relative error of the duration (``plan.duration_tolerance``) [-].
PLAN_TOLERANCE = 5e-4
#: Largest plan.duration_tolerance accepted, exclusive (a 10 % error in the duration is no longer an optimum) [-].
MAX_PLAN_TOLERANCE = 0.1
#: Adaptive planner grid: uniform points of the initial grid (grading, breaks and knots added) [-].
GRID_INITIAL_POINTS = 200
#: Adaptive planner grid: most refinement iterations and most grid points; beyond either the plan is
#: returned with its (larger) error estimate and a warning [-].
GRID_MAX_REFINEMENTS = 16
GRID_MAX_POINTS = 200_000
#: Memory a plan holds, an upper estimate: PLAN_MEMORY_BASE plus PLAN_BYTES_PER_POINT_JOINT per grid point and
#: joint [bytes]. Measured (tracemalloc peak of plan with baselines, 6 joints): 1.12 GB on the 100-move contour's
#: 158,000 points (7.1 KB per point), 69 MB on a 30-segment zigzag's 3,055 points, 16 MB on a fixed grid of
#: 3,024 points on one line. A grid whose estimate exceeds MEMORY_FRACTION of the machine's available memory
#: is refused before it is built, and the adaptive grid stops at the largest that fits (planner.py).
PLAN_MEMORY_BASE = 128 * 2**20
PLAN_BYTES_PER_POINT_JOINT = 1_400
#: Joint speed limit above which a limits file or [limits] velocity gets a "degrees?" warning [rad/s]
#: (1,146 deg/s; the IRB140's fastest joint turns at 450 deg/s = 7.9 rad/s).
PLAUSIBLE_JOINT_SPEED = 20.0
#: Share of the available memory (MemAvailable) one run may plan to use [-].
MEMORY_FRACTION = 0.5
#: Adaptive planner grid: rounds of halving the intervals whose certified limit bound exceeds the
#: tolerance before the verify-and-tighten loop tightens limits instead [-].
PLAN_MAX_REFINE_ROUNDS = 4
#: ... and this many intervals on each side of every such interval: re-solving on the finer grid moves the profile,
#: and the next round's excess was on the neighbours of the last round's (median distance one interval on a
#: 1,000-move contour, at most two for 90 %), so halving them at once saves the rounds (each a full solve) [-].
PLAN_REFINE_NEIGHBOURS = 2
#: Gravity vector [m/s^2].
GRAVITY = (0.0, 0.0, -9.81)
#: Inverse-kinematics position / orientation tolerance for FK(IK(pose)) [m], [rad].
IK_TOLERANCE = 1e-9
#: Damped-least-squares IK: damping [-], iterations.
DLS_DAMPING = 1e-6
DLS_MAX_ITERATIONS = 200
#: Damped-least-squares IK: largest joint step per iteration [rad] and damping growth factor [-].
DLS_MAX_STEP = 0.5
DLS_DAMPING_GROWTH = 10.0
#: Lift of an arm without closed-form IK and without path.start_configuration: the first point's IK
#: is tried from the zero configuration, the middle of the joint ranges, then this many seeded random
#: configurations in the ranges (deterministic: seed DLS_RANDOM_START_SEED) before the path is refused.
DLS_RANDOM_STARTS = 16
DLS_RANDOM_START_SEED = 0
#: Closed-form (OPW) IK: tolerance of the structure detection and of its FK check [m, rad];
#: configurations (seeded) on which the detected parameters are checked against Pinocchio's FK.
OPW_TOLERANCE = 1e-9
OPW_CHECK_CONFIGURATIONS = 32
OPW_CHECK_SEED = 0
#: Closed-form IK: |sin q5| (wrist) or distance of the wrist centre from axis 1 [m] (shoulder)
#: below which the split of the redundant angle is taken from the reference configuration.
IK_DEGENERATE = 1e-12
#: Closed-form IK: |cos| of the elbow angle may exceed 1 by this much (rounding) and still count
#: as the stretched arm [-].
IK_REACH_ROUNDING = 1e-12
#: Batch IK: largest joint change between consecutive points [rad]; a larger jump means the
#: path crosses (or passes too near) a singularity at the given point spacing.
IK_MAX_JOINT_STEP = 1.5707963267948966
#: Allowed deviation of a pose rotation matrix from orthonormality, max |R^T R - I| [-].
ROTATION_TOLERANCE = 1e-6
#: Singularity measure threshold: smallest singular value of the 6x6 Jacobian below which a
#: configuration is reported as (near) singular [m or rad per rad].
SINGULARITY_THRESHOLD = 1e-3
#: Wrist singularity (q5 = 0) along a lifted path (pathmotion.lift.wrist_crossing). A path that passes it
#: closer than WRIST_CROSSING_TOLERANCE [rad of q5] crosses it: the lift takes the smooth branch (q5
#: changes sign; the pose error of treating it as exact is at most this, below IK_TOLERANCE). Farther,
#: q4 and q6 must turn by about pi nearby (a wrist flip).
WRIST_CROSSING_TOLERANCE = 1e-12
#: |q5| [rad] below which Phi and its derivatives come from the certified local interpolant of the
#: continuous IK instead of J^-1 (the Jacobian's condition number grows like 1/|q5|).
WRIST_WINDOW = 0.05
#: Largest half-width [m of theta] of that window (a tangential touch of q5 = 0 has q5' = 0).
WRIST_WINDOW_MAX = 0.05
#: The interpolant's TCP pose must match the path between its nodes to this [m, rad].
WRIST_FIT_TOLERANCE = 1e-10
#: Reported wrist passages: stretches of the path with |sin q5| below this [-].
WRIST_PASSAGE = 0.1
#: A suggested tool rotation must keep |sin q5| at least this far from 0 along the whole path [-].
WRIST_CLEARANCE = 0.05
#: Largest tool rotation [deg] the flip error searches for that suggestion (in 1 deg steps).
WRIST_MAX_TOOL_ROTATION = 45
#: Fitted (thesis) profile: margin below the optimum [-].
FITTED_PROFILE_MARGIN = 0.05
#: Closed-loop verdict (ISO 9283 terms): the TCP must stay within this distance of the PLANNED path, and
#: arrives when it is this close to the end point [m].
PATH_TOLERANCE = 1e-3
#: Closed-loop verdict: the tool's orientation must stay within this angle of the PLANNED orientation (ISO 9283's
#: orientation path accuracy, ATo) [deg]: 1 mm at a tool lever of about 0.11 m.
PATH_TOLERANCE_DEG = 0.5
#: Closed-loop verdict: joint deviation |q - Phi(theta)| (max over joints) beyond which tracking has failed
#: [rad]; a coarse backstop behind the path tolerance (0.05 rad is 25 mm at 0.5 m of reach).
JOINT_TOLERANCE = 0.05
#: Closed-loop verdict: longest stretch a joint torque may stay clipped at its limit [s]. 50 ms is about the
#: settling time of the 40 rad/s loops: a saturation that long means the feedback has lost authority.
SATURATION_LIMIT = 0.05
#: Plant integration sub-steps per controller sample (RK4): 2 ms steps at the 4 ms sample time. With the
#: drives' armature in the model, the IRB140's state after 1 s of a torque that moves the joints by 4 rad
#: is within 1.3e-9 rad of a DOP853 reference at rtol 1e-10 (2.2e-8 rad with one step per sample).
PLANT_SUBSTEPS = 2
#: Most plant sub-steps per controller sample (simulate.substeps, or the count the friction needs) [-].
MAX_PLANT_SUBSTEPS = 1000
#: The closed loop's plant: "builtin" (Pinocchio ABA + our RK4) or "mujoco" (MuJoCo's parse of the same URDF,
#: MuJoCo's RK4; needs pip install "pathmotion[mujoco]").
PLANT = "builtin"
#: Spacing of the dense reference samples the lift takes along a task path [m of theta].
LIFT_REFERENCE_STEP = 0.002
#: Most points of that dense reference: a longer path is far beyond any arm's reach [-].
LIFT_MAX_REFERENCE_SAMPLES = 100_000
#: Arms with more than 6 joints: rate [1/m of theta] at which the null-space motion pulls the joints
#: toward the start configuration (pathmotion.robot.redundancy); 0 = pure minimum joint speed.
REDUNDANCY_NULLSPACE_GAIN = 2.0
#: Waypoint files (CSV): largest size [bytes]; a quaternion whose norm differs from 1 by more than
#: the tolerance is an input error, not rounding [-].
MAX_WAYPOINT_FILE_BYTES = 16 * 1024 * 1024
QUATERNION_NORM_TOLERANCE = 1e-3

# --- Task-space geometry (pathmotion.geometry) -------------------------------------------------
#: Default tool orientation R (world_vector = R @ tool_vector; its columns are the tool x, y, z
#: axes in world coordinates): tool z pointing down (= -world z), tool x = world x, i.e. a
#: rotation of pi about world x.
TOOL_DOWN_ROTATION = ((1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0))
#: Largest gap between the end of one segment and the start of the next [m].
PATH_GAP_TOLERANCE = 1e-9
#: Shortest segment accepted (anything shorter is "zero length") [m].
MIN_SEGMENT_LENGTH = 1e-9
#: Angle between the tangents above which a connection is a sharp corner [rad].
CORNER_ANGLE_TOLERANCE = 1e-7
#: Jump of the curvature vector above which a G1 connection is "tangent" rather than "smooth" [1/m].
CURVATURE_JUMP_TOLERANCE = 1e-6
#: Out-of-plane tolerance (sine of the angle between plane normals) for planar-corner checks [-].
PLANARITY_TOLERANCE = 1e-9
#: Relative accuracy of certified maximum-distance computations (upper - lower <= this * upper) [-].
DEVIATION_RELATIVE_ACCURACY = 1e-4
#: Most live intervals of the certified deviation search; beyond it (a flat maximum, e.g. a blend that
#: lies on the path) the search stops with a valid but wider bracket instead of doubling on [-].
DEVIATION_MAX_INTERVALS = 1 << 16
#: G2 blend shape in (0, 1]: the end speed is lambda = 5/2 * shape * cut, so for a line-line corner
#: b2 sits at (1 - shape) * cut from the corner (b2 = corner when 1) [-]. 0.7 keeps the peak
#: curvature within ~15 % of its minimum over shape for 30-90 degree corners at a given deviation
#: while keeping d(curvature)/ds moderate; see pathmotion.geometry.blends and docs/geometry.md.
G2_BLEND_SHAPE = 0.7
#: Fraction of a neighbouring segment that one blend may consume when several corners are blended
#: in one call (each end of a segment may be blended) [-].
SHARED_SEGMENT_FRACTION = 0.5
#: Thesis paths (Chapter 6-7): horizontal circle centre [m] (its z is the height), radius [m],
#: radial line length [m], vertical circle radius [m], transition circle radius r_t [m].
THESIS_CIRCLE_CENTRE = (0.5, 0.0, 0.5)
THESIS_CIRCLE_RADIUS = 0.1
THESIS_LINE_LENGTH = 0.1
THESIS_VERTICAL_CIRCLE_RADIUS = 0.1
THESIS_TRANSITION_RADIUS = 0.04
#: Planner: verify-and-tighten iterations (resample, tighten limits locally, re-solve) before giving up.
PLAN_MAX_TIGHTEN_ITERATIONS = 8
#: Planner: upper bound on x = theta_dot^2 where no limit bounds it (e.g. Phi' = 0 with only velocity
#: limits) [(unit theta / s)^2]; a "max" boundary velocity that reaches it is reported as unbounded.
PLANNER_X_CAP = 1e8
#: Segment-by-segment planning with "max" connections: length of the interval that carries the jump in
#: theta_dot at a connection, as a fraction of the local grid step [-].
CONNECTION_JUMP_FRACTION = 1e-3
#: Fitted (thesis) profile: polynomial degree (or 2 x number of harmonics on periodic paths) of the fit
#: of log(theta_dot) in theta.
FITTED_PROFILE_DEGREE = 6
#: Relative tolerance of the searches over a boundary velocity (periodic cycle, industrial baseline) [-].
PLANNER_SEARCH_TOLERANCE = 1e-9

# --- Closed loop: controllers (pathmotion.control) and plant (pathmotion.simulation) ---------------
#: Orbital controller: closed-loop natural frequency [rad/s] and damping ratio [-] of the transverse
#: position error; they set the LQR weights Q = diag(w^4, 2 w^2 (2 zeta^2 - 1), ...), R = I.
ORBITAL_BANDWIDTH = 40.0
ORBITAL_DAMPING = 1.0
#: Orbital controller: convergence rate of the speed deviation I = theta_dot^2 - x*(theta) [1/s],
#: and the joint speed along the path [rad/s] below which its weight stops growing.
ORBITAL_SPEED_RATE = 20.0
ORBITAL_MIN_SPEED = 0.05
#: Orbital controller: design the gains on the transverse linearization sampled at the controller's sample
#: time with its command delay in the model (discrete periodic/time-varying Riccati on the exactly sampled
#: continuous cost, so the gains tend to the continuous design's as the sample time goes to 0), instead of in
#: continuous time (False: the continuous design, sampled as it is). Stable at 12 ms with a delay of one or two
#: samples where the continuous design diverges (docs/control.md, robustness matrix).
ORBITAL_SAMPLED_DESIGN = True
#: Orbital controller: rate [rad/s] of the integral action on the transverse error (closed-loop pole of
#: the integrator; 0 turns it off). Rejects constant unmodelled torques such as a payload's gravity.
ORBITAL_INTEGRAL_RATE = 20.0
#: Orbital controller: the disturbance observer (pathmotion.control.observer) gets the largest gain with which the
#: sampled loop, with its delay, stays stable for any plant inertia between 1/F and F times the model's, F this
#: [-]. 3 covers the IRB140's rated 6 kg at 0.1 m beyond the flange unknown to the model (up to 2.6x the
#: modelled inertia) or believed in but absent (down to 0.39x). inf: no observer.
ORBITAL_OBSERVER_RANGE = 3.0
#: Orbital controller: identify online the flange payload (mass, first moment) and the joint friction the model
#: lacks (pathmotion.control.payload: a Kalman filter on the disturbance observer's residual; the computed torque
#: adds the estimate, the observer sees the rest). ``[simulate] identify_payload``.
PAYLOAD_IDENTIFICATION = True
#: Payload identification: correlation time [s] of the parameters (Gauss-Markov prior; the forgetting: what the
#: motion stops exciting relaxes to the prior) (``[simulate] gains.payload_memory``).
PAYLOAD_MEMORY = 10.0
#: Payload identification: a sample's residual is weighted as a joint acceleration error of standard deviation
#: sqrt(PAYLOAD_NOISE^2 + 2 (PAYLOAD_SPEED_NOISE / Ts)^2): what no payload and friction explain (link inertia
#: errors, the payload's rotational inertia) [rad/s^2], and the measured joint speed's noise [rad/s] differenced over
#: a sample (twice docs/control.md's realistic 1e-3 rad/s: 0.71 rad/s^2 at 4 ms, 2.8 at 1 ms)
#: (``[simulate] gains.payload_noise``, ``gains.payload_speed_noise``).
PAYLOAD_NOISE = 1.0
PAYLOAD_SPEED_NOISE = 2.0e-3
#: Payload identification prior: lever [m] of the payload's centre of mass from the flange body's frame (the
#: scale of m c), and, for robots without a rated payload in RATED_PAYLOAD, the prior mass as this fraction of the
#: arm's link mass [-].
PAYLOAD_LEVER = 0.2
PAYLOAD_MASS_FRACTION = 0.1
#: Below this identified payload mass [kg] the summary gives no centre of mass (m c / m would be noise).
IDENTIFIED_MASS_FLOOR = 0.1
#: An identified payload mass is reported when it is at least this many standard errors (the filter's) from 0;
#: a smaller one is what the model lacks at the flange (link inertia errors, noise), not a payload [-].
IDENTIFIED_SIGNIFICANCE = 2.0
#: Payload identification prior: each joint's Coulomb friction as this fraction of its torque limit, its viscous
#: friction reaching the same at the velocity limit (standard deviations) [-].
FRICTION_PRIOR_FRACTION = 0.05
#: Orbital controller: planned time [s] by which the clock play is widened on each side of a slow stretch
#: (planned joint speed below ORBITAL_MIN_SPEED: stops, ends of open paths). Near a stop the speed channel's
#: authority (about speed_rate x planned joint speed / 2 in joint acceleration) falls below what friction and
#: model error take: with 40 ms a realistic plant (Realism.realistic) stalled short of the end of a clamped
#: spline; 0.1 s brings the clock play in first.
TERMINAL_TIME_TO_GO = 0.1
#: Closed loop: keep the controller's path table and orbital design in an on-disk cache ($PATHMOTION_CACHE_DIR,
#: else $XDG_CACHE_HOME/pathmotion or ~/.cache/pathmotion), keyed by the path, plan, gains and settings.
DESIGN_CACHE = True
#: Points of the controller's path table (quintic Hermite in theta, breaks added) [-].
PATH_TABLE_POINTS = 2001
#: Path projection: most Newton iterations per sample [-] (it stops at the step tolerance, usually after
#: one or two), step tolerance [unit theta, relative to the path length] and largest step per iteration
#: [fraction of the path length].
PROJECTION_ITERATIONS = 6
PROJECTION_TOLERANCE = 1e-10
PROJECTION_MAX_STEP = 0.02
#: Riccati equation: relative tolerance of the ODE solver and of the periodic fixed point [-],
#: and the most periods iterated for a closed path.
RICCATI_TOLERANCE = 1e-7
RICCATI_MAX_PERIODS = 50
#: Riccati differential equation: planned time between its knots [s], one compiled RK4 step each (the gains are
#: linear in theta between knots). The closed-loop poles are ~20-60 rad/s, so h * lambda <= 0.12 and the gains
#: stay within ~1e-4 of an adaptive RK45 on the full table grid (tests/test_control_riccati.py).
RICCATI_KNOT_TIME = 2e-3
#: Time-indexed computed-torque baseline: natural frequency [rad/s] and damping ratio [-].
COMPUTED_TORQUE_BANDWIDTH = 40.0
COMPUTED_TORQUE_DAMPING = 1.0
#: PD + gravity baseline (decentralized industrial joint loop): natural frequency [rad/s] and
#: damping ratio [-] per joint, gains scaled by the diagonal of M at the start configuration.
PD_BANDWIDTH = 40.0
PD_DAMPING = 1.0
#: Closed-loop time budget: factor on the planned duration [-] plus a margin [s].
TIME_BUDGET_FACTOR = 3.0
TIME_BUDGET_MARGIN = 1.0
#: Open paths ending at rest: after the TCP has arrived within PATH_TOLERANCE of the end point, the
#: simulation runs this much longer, holding the final configuration, to measure the settling [s].
SETTLE_TIME = 0.1
#: Divergence: a joint speed above this multiple of its velocity limit ends the run as diverged [-].
DIVERGENCE_SPEED_FACTOR = 10.0
#: Realistic-plant preset (Realism.realistic): relative mass/inertia error per link [-], unmodelled
#: payload [kg] and its centre of mass in the flange frame [m], viscous [N m s/rad] and Coulomb
#: [N m] friction per joint, Coulomb smoothing speed [rad/s], encoder resolution [rad] (20-bit per
#: motor turn through a ~100:1 gear), position [rad] and velocity [rad/s] noise (standard deviations).
REALISTIC_INERTIA_ERROR = 0.10
REALISTIC_PAYLOAD_MASS = 6.0
REALISTIC_PAYLOAD_COM = (0.0, 0.0, 0.1)
#: Realistic-plant preset: principal moments of inertia of the unmodelled payload about its centre of
#: mass [kg m^2]: a point mass, as in the IRB140 torque estimates (6 kg, 0.1 m beyond the flange).
REALISTIC_PAYLOAD_INERTIA = (0.0, 0.0, 0.0)
#: Realistic-plant preset friction, joint side. Wrist axes: the PUMA 560's motor-side figures times the gear
#: ratio squared (viscous) and times the ratio (Coulomb), 0.4 N m s/rad and 0.8 N m (Corke and
#: Armstrong-Helouvry 1994, in Corke's Robotics Toolbox mdl_puma560); axes 1-3 a few times larger.
REALISTIC_VISCOUS_FRICTION = (2.0, 2.0, 1.5, 0.4, 0.4, 0.3)
REALISTIC_COULOMB_FRICTION = (3.0, 3.0, 2.0, 0.8, 0.8, 0.5)
COULOMB_SMOOTHING_SPEED = 0.05
REALISTIC_ENCODER_RESOLUTION = 6.0e-8
REALISTIC_POSITION_NOISE = 1.0e-5
REALISTIC_VELOCITY_NOISE = 1.0e-3
#: Industrial baseline: relative tolerance of the search for the highest constant TCP speed [-].
BASELINE_SPEED_TOLERANCE = 1e-6
#: Planner grid: extra points at step/2, step/4, ... (this many levels) on both sides of every path end
#: and segment connection, where the profile may leave or reach rest with Phi' = 0 (the discretization
#: error there is first order in the step; grading makes it negligible).
GRID_GRADING_LEVELS = 12
#: Study: a segment of a blended task path whose midpoint is farther than this from the original
#: (sharp) path is a blend [m] (blend_speed_scale acts on it).
BLEND_DETECTION_DISTANCE = 1e-7
#: Study: fewest planner grid points on a piece of path re-planned around a slowed blend [-].
BLEND_PIECE_MIN_POINTS = 50
#: Corner atlas (`pathmotion corners --meshes`): the free-shape references' meshes (total intervals, each twice
#: the last). Not free_shape.MESHES' 200 intervals, which cost minutes per solve (30 deg / 1 mm's whole tube hit
#: IPOPT's iteration cap there from two starts and took 7 minutes); benchmarks/refine_references.py solves
#: the references on more meshes.
ATLAS_MESHES = (25, 50, 100)
#: Study score: seconds of cycle time one metre of mean TCP deviation from the sharp path costs [s/m]
#: (100 s/m: 1 mm of mean deviation weighs as much as 0.1 s of cycle time).
STUDY_ERROR_WEIGHT = 100.0
#: Study: points of the sharp-path polyline stored with each traced sweep point (for figures).
STUDY_TRACE_PATH_POINTS = 2000
#: HTML report: most samples drawn per trace (longer signals are decimated uniformly, ends kept) [-].
REPORT_MAX_POINTS = 2000
#: HTML report: frames of the 3-D arm animation (decimated samples of the motion) [-].
REPORT_ARM_FRAMES = 100
#: HTML report: shortest time a frame of the arm animation is shown [s] (slower motions play in real time).
REPORT_MIN_FRAME_TIME = 0.04
#: Planner: limits linearized around the previous solution (torque-speed envelope) are re-solved at
#: most this many times, until the duration changes by less than this fraction [-].
RELINEARIZE_ITERATIONS = 12
RELINEARIZE_TOLERANCE = 1e-5
#: Feedback reserve ([limits] torque_reserve): the fraction of each torque limit kept free stays below this [-].
MAX_TORQUE_RESERVE = 0.5
#: Feedback reserve when none is given ([limits] torque_reserve, corners --torque-reserve) [-]: the plan uses at most
#: 77.5 % of each torque limit and leaves the rest to the feedback controller, as an industrial path planner does.
#: Measured (benchmarks/irb140_torque_reserve.py, docs/robot.md): the smallest reserve with which the IRB140's closed
#: loop tracks on a plant with 10 % inertia error, 1 kg of unmodelled payload and 2 % unmodelled Coulomb friction,
#: over 11 shipped scenarios and 18 seeded random circles, polylines and blended polylines, was 0 to 0.225 (median
#: 0.1), and 0.225 tracked on every one of them.
TORQUE_RESERVE = 0.225
#: torque_reserve = "auto": the reserves searched are 0, AUTO_RESERVE_STEP, 2 AUTO_RESERVE_STEP, ...,
#: AUTO_RESERVE_MAX [-] (a bisection: at most 6 plan + closed-loop runs for 0.45 in steps of 0.025; a step
#: of 2.5 % of the torque changes the plan's duration by about 1.5 % on the IRB140 circle).
AUTO_RESERVE_MAX = 0.45
AUTO_RESERVE_STEP = 0.025

# --- Input files and output folders (pathmotion.io.files) ------------------------------------------
#: Largest scenario or limits file (TOML) read [bytes]; real ones are a few kB.
MAX_TOML_BYTES = 10_000_000
#: Largest URDF read [bytes] (meshes are separate files; a detailed arm's URDF is well below 1 MB).
MAX_URDF_BYTES = 50_000_000
#: Largest result file (CSV, JSON) the report reads [bytes]: 2e6 samples of 40 columns.
MAX_RESULT_BYTES = 2_000_000_000
#: Deepest TOML nesting (arrays / inline tables) and most parts of one dotted key [-]; a scenario needs 4.
MAX_TOML_DEPTH = 32
#: Most <link> (and most <joint>) elements of a URDF [-]: arms have tens; each costs parse time and memory.
MAX_URDF_LINKS = 1000
#: Longest file name component and whole path accepted [bytes] (Linux NAME_MAX and PATH_MAX).
MAX_NAME_BYTES = 255
MAX_PATH_BYTES = 4095
#: Largest controller gain [rad/s or 1/s] accepted from a scenario: far above any sample rate a
#: controller can realise (4 ms: Nyquist 785 rad/s), far below overflow of its LQR weights (w^4).
MAX_GAIN = 1.0e4

#: Rated payload [kg] of the built-in robots, by name: a scenario payload above it is reported as a likely
#: unit slip (grams for kg). IRB140: 6 kg (ABB IRB 140-6/0.8, official).
RATED_PAYLOAD = {"irb140": 6.0}
#: Planner, third-order limits (jerk, torque rate): sequential LP stops when the duration changes by
#: less than this fraction, or after this many LPs [-].
THIRD_ORDER_TOLERANCE = 1e-4
THIRD_ORDER_ITERATIONS = 60
#: Planner, third-order limits: uniform grid points of the default grid (grid_points unset), plus the
#: usual grading towards the ends and connections. The smooth profile's duration on it is within 0.62 %
#: of the converged optimum on the circle cases of benchmarks/bench_third_order.py [-].
THIRD_ORDER_GRID_POINTS = 100
#: EGM (pathmotion execute / virtual-robot): the UDP port ABB's examples and abb-robot-client use.
EGM_PORT = 6510
#: EGM: largest joint distance [rad] between the robot's first reported joints and the plan's start before
#: execute refuses to move (0.01 rad ~ 0.6 deg: a robot jogged to the start by hand is within it).
EGM_START_TOLERANCE = 0.01
#: execute PLAN_DIR: largest joint difference [rad] between the plan rebuilt from the folder (scenario.toml,
#: phase_plane.csv) and its trajectory.csv before the folder is refused as edited or from another version.
PLAN_FOLDER_TOLERANCE = 1e-6
#: EGM: the controller counts as silent (execute stops along the path) after this long without a message [s].
EGM_SILENCE = 0.1
#: EGM: execute waits this long for the controller's first message before giving up [s].
EGM_FIRST_MESSAGE_TIMEOUT = 30.0
#: EGM: a robot message answered later than this after it arrived counts as late [s] (one EGM cycle).
EGM_LATE = 0.004
#: EGM: the virtual robot sends a robot message again after this long without an answer (--lockstep) [s],
#: and gives up after this many silent repeats (before the sensor's first answer: after
#: EGM_FIRST_MESSAGE_TIMEOUT, as execute waits for the robot's first message).
EGM_RESEND = 0.05
EGM_RESEND_LIMIT = 100
#: EGM: the virtual robot keeps streaming this long after the sensor's references come to rest [s] (the arm
#: settles; residual vibration is measured there).
EGM_SETTLE_WINDOW = 0.3
#: EGM: largest datagram read [bytes] (UDP's own maximum); a larger one is truncated and rejected.
EGM_MAX_DATAGRAM = 65536
#: EGM: the reference is tabulated on this time step before streaming (linear interpolation between
#: samples: error qdd dt^2 / 8, ~1e-6 rad at 10 rad/s^2) [s].
EGM_TABLE_STEP = 0.001
#: EGM, --correction shaping/orbital: learning iterations refining the plan's references on the nominal arm
#: before streaming (execution/refine.py; 0: the analytic shaping alone), and the TCP RMS error [m] that ends
#: them early.
EGM_REFINE_ITERATIONS = 12
EGM_REFINE_TOLERANCE = 1e-5
#: EGM refinement: the error counted this long [s] after the table's end (the arm settling), the response
#: model's length [s], its regularisation and its smoothness weight (both relative to the largest diagonal
#: of G^T G).
EGM_REFINE_TAIL = 0.15
EGM_REFINE_SETTLE = 0.05
EGM_REFINE_HORIZON = 0.3
EGM_REFINE_REGULARIZATION = 1e-2
EGM_REFINE_SMOOTHING = 1.0
#: EGM refinement: each joint's error counts by the TCP's motion per radian of it, at least this fraction of the
#: largest (a wrist axis through the TCP still counts).
EGM_REFINE_WEIGHT_FLOOR = 0.05
#: EGM, --correction shaping/orbital on a second-order plan: at most this many plans with lower limits until the
#: shaped motion keeps the plan's limits (execution/shaped_limits.py).
EGM_SHAPED_REPLANS = 6
#: EGM, --correction shaping/orbital on a second-order plan: at most this many slower re-timings of a stop, an
#: override or a resume until its shaped motion keeps the plan's limits (execution/session.py).
EGM_RETIME_TIGHTEN = 3
#: EGM refinement: a re-timed segment (stop, override, resume) fades the correction out over this long [s]
#: (about the IRB 140's slowest gear period).
EGM_REFINE_FADE = 0.05
#: EGM, --correction orbital: the phase [rad] the drives' lag takes at the transverse integral loop's crossover
#: (0.25 rad: the loop's bandwidth a quarter of what the lag allows, so that it follows slow errors only);
#: the gain per cycle follows from the drive file's lag (execution/orbital.py, loop_gain): 0.05 on the IRB 140.
EGM_ORBITAL_CROSSOVER_PHASE = 0.25
#: EGM: a stop, override or resume request at robot time t switches to its re-timed segment at t + this lead
#: [s] (execute --switch-lead): the motion until then is the current segment, so the re-timing starts from a
#: known state and runs off the loop while the loop answers from the current segment; 0: the re-timing runs
#: on the cycle that takes the request (its answer, and those behind it, wait for it).
EGM_SWITCH_LEAD = 0.02
#: EGM, real time (execute without --lockstep): a switch whose re-timing is not ready at its time is
#: scheduled again from a later state, at least this many times its re-timing's compute time after the
#: re-timing ends [-], at most EGM_SWITCH_RETRIES times; then it is waited for (answers late). A request's
#: lead is at least this many times what the last re-timing of its kind took.
EGM_SWITCH_MARGIN = 1.5
EGM_SWITCH_RETRIES = 3
#: EGM: Python's thread switch interval while execute serves [s] (the re-timing worker hands the loop the
#: interpreter within about this long; Python's default is 5 ms, more than an EGM cycle).
EGM_SWITCH_INTERVAL = 0.0002
#: EGM: the re-timing worker thread runs this much nicer than execute's loop (Linux thread priority) [-].
EGM_WORKER_NICE = 10
#: EGM: the same with execute's loop at a real-time priority (--realtime-priority): SCHED_FIFO already runs the
#: loop first, and a worker holding Python's interpreter lock gives it back to the loop only once it runs (a
#: nicer worker waits longer for its turn behind the machine's other processes) [-].
EGM_WORKER_NICE_REALTIME = 0
#: EGM: execute's loop thread runs at this SCHED_FIFO priority, its process's memory locked (execute
#: --realtime-priority, 1-99 on Linux); 0: normal scheduling [-].
EGM_REALTIME_PRIORITY = 0
