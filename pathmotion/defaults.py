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
#: Planner grid points per path (whole chain) unless a scenario says otherwise.
GRID_POINTS = 1000
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
#: Fitted (thesis) profile: margin below the optimum [-].
FITTED_PROFILE_MARGIN = 0.05
#: Closed-loop tracking failure threshold on joint deviation |q - Phi(theta)| [rad].
TRACKING_FAILURE_THRESHOLD = 0.05
#: Plant integration sub-steps per controller sample (RK4).
PLANT_SUBSTEPS = 4
#: Spacing of the dense reference samples the lift takes along a task path [m of theta].
LIFT_REFERENCE_STEP = 0.002
