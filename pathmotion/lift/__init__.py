"""The lift: a task path turned into the joint-space constraint q = Phi(theta) that every later stage takes.

* :mod:`.joint_path` -- :class:`JointPath`, the constraint's interface, and :class:`SplineJointPath`
  (a clamped spline through joint waypoints).
* :mod:`.constraint` -- :func:`lift`: closed-form IK or a resolved-rate ODE along a task path, with
  exact Phi', Phi'', Phi''' (:class:`TaskJointPath`).
* :mod:`.wrist_crossing` -- the wrist singularity (q5 = 0) along a lifted path: smooth crossings,
  near passes and flips.
"""

import sys
import types

from .constraint import (PathCheck, ResolvedRateJointPath, TaskJointPath, joint_derivatives,
                         joint_third_derivative, lift, tcp_jerk_bias)
from .joint_path import JointPath, SplineJointPath

__all__ = ["JointPath", "PathCheck", "ResolvedRateJointPath", "SplineJointPath", "TaskJointPath",
           "joint_derivatives", "joint_third_derivative", "lift", "tcp_jerk_bias"]


class _CallableModule(types.ModuleType):
    """This package is also the function it is named after: importing ``pathmotion.lift`` binds the
    package to the attribute ``pathmotion.lift``, so ``pathmotion.lift(robot, task)`` calls :func:`lift`."""

    def __call__(self, *args, **kwargs):
        return lift(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
