"""EGM messages: ABB's egm.proto as abb-robot-client ships it (``abb_robot_client.egm.egm_pb2``).

Joints travel in degrees (ABB's convention); everything in pathmotion is radians. Decoding checks what a
foreign or damaged datagram can break: protobuf framing, required fields, the joint count, finiteness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import ExecutionError

try:
    from abb_robot_client.egm import egm_pb2
    from google.protobuf.message import DecodeError
except ImportError as exc:  # the [egm] extra
    egm_pb2 = None
    _MISSING = exc
else:
    _MISSING = None

#: header.mtype of every sensor message: joint references are corrections (ABB's EGM sensor protocol).
SENSOR_MTYPE = "MSGTYPE_CORRECTION"
#: Degrees per radian and radians per degree, as numpy's degrees/radians multiply (the same doubles).
_DEG, _RAD = 180.0 / math.pi, math.pi / 180.0


def require_egm():
    """egm_pb2, or an error saying how to install it."""
    if egm_pb2 is None:
        raise ExecutionError(f"EGM needs abb-robot-client (ABB's egm.proto): pip install 'pathmotion[egm]' ({_MISSING})")
    return egm_pb2


class RobotMessage(NamedTuple):
    """A decoded EgmRobot: seqno, tm [ms], joints (n,) [rad] (feedBack), planned (n,) [rad] or None,
    motors_on, rapid_running."""

    seqno: int
    tm: int
    joints: np.ndarray
    planned: np.ndarray | None
    motors_on: bool
    rapid_running: bool


def _parse(msg, data: bytes, what: str):
    """``msg`` (an egm_pb2 message) parsed from ``data``, its required fields checked."""
    try:
        msg.ParseFromString(data)
    except (DecodeError, RuntimeError, ValueError) as exc:
        raise ExecutionError(f"{what}: {len(data)} bytes are not an {msg.DESCRIPTOR.name} ({exc})") from None
    if not msg.IsInitialized():
        raise ExecutionError(f"{what}: {msg.DESCRIPTOR.name} lacks required fields {msg.FindInitializationErrors()}")
    return msg


def _joints(values, what: str) -> np.ndarray:
    q = [v * _RAD for v in values]
    if not all(map(math.isfinite, q)):
        raise ExecutionError(f"{what}: joints are not finite: {list(values)}")
    return np.array(q)


class RobotDecoder:
    """EgmRobot datagram -> RobotMessage (ExecutionError when it is not one or carries no joints), parsing into
    one EgmRobot kept for every call (a parse replaces its whole content): execute's per-cycle decoder."""

    def __init__(self):
        pb = require_egm()
        self._msg = pb.EgmRobot()
        self._on, self._running = pb.EgmMotorState.MOTORS_ON, pb.EgmRapidCtrlExecState.RAPID_RUNNING

    def __call__(self, data: bytes) -> RobotMessage:
        msg = _parse(self._msg, data, "robot message")
        if not msg.HasField("header") or not msg.HasField("feedBack") or not msg.feedBack.HasField("joints") \
                or not len(msg.feedBack.joints.joints):
            raise ExecutionError("robot message: no header or no feedBack.joints (is the controller in joint mode?)")
        planned = None
        if msg.HasField("planned") and len(msg.planned.joints.joints):
            planned = _joints(msg.planned.joints.joints, "robot message planned")
        header = msg.header
        return RobotMessage(
            int(header.seqno), int(header.tm), _joints(msg.feedBack.joints.joints, "robot message feedBack"), planned,
            msg.HasField("motorState") and msg.motorState.state == self._on,
            msg.HasField("rapidExecState") and msg.rapidExecState.state == self._running)


def decode_robot(data: bytes) -> RobotMessage:
    """An EgmRobot datagram -> RobotMessage (ExecutionError when it is not one or carries no joints)."""
    return RobotDecoder()(data)


def encode_robot(seqno: int, tm: int, joints: np.ndarray, planned: np.ndarray, motors_on: bool = True,
                 rapid_running: bool = True) -> bytes:
    """An EgmRobot datagram (joints, planned (n,) [rad]; tm [ms])."""
    pb = require_egm()
    msg = pb.EgmRobot()
    msg.header.seqno = seqno & 0xFFFFFFFF
    msg.header.tm = int(tm) & 0xFFFFFFFF
    msg.header.mtype = pb.EgmHeader.MSGTYPE_DATA
    msg.feedBack.joints.joints.extend(np.degrees(joints).tolist())
    msg.planned.joints.joints.extend(np.degrees(planned).tolist())
    msg.motorState.state = pb.EgmMotorState.MOTORS_ON if motors_on else pb.EgmMotorState.MOTORS_OFF
    msg.rapidExecState.state = (pb.EgmRapidCtrlExecState.RAPID_RUNNING if rapid_running
                                else pb.EgmRapidCtrlExecState.RAPID_STOPPED)
    return msg.SerializeToString()


@dataclass(frozen=True)
class SensorMessage:
    """A decoded EgmSensor: seqno, tm, mtype name, joints (n,) [rad], speed (n,) [rad/s] or None, done."""

    seqno: int
    tm: int
    mtype: str
    joints: np.ndarray
    speed: np.ndarray | None
    done: bool = False


class SensorEncoder:
    """EgmSensor datagrams from one EgmSensor kept for every call (its fields overwritten, the speed references
    cleared when there are none; its header, digital signal and joint containers held, not looked up per
    message): execute's per-cycle encoder."""

    def __init__(self):
        pb = require_egm()
        self._msg = msg = pb.EgmSensor()
        msg.header.mtype = pb.EgmHeader.MessageType.Value(SENSOR_MTYPE)
        self._header, self._signal, self._joints = msg.header, msg.RAPIDtoRobot, msg.planned.joints.joints
        self._speed = None  # speedRef's joints while it is set

    def __call__(self, seqno: int, tm: int, joints: np.ndarray, speed: np.ndarray | None,
                 done: bool = False) -> bytes:
        """An EgmSensor datagram: planned.joints (n,) [rad] and speedRef.joints (n,) [rad/s] when given; ``done``:
        RAPIDtoRobot.digVal, the motion is over (the RAPID program may end its EGM session)."""
        self._header.seqno = seqno & 0xFFFFFFFF
        self._header.tm = int(tm) & 0xFFFFFFFF
        self._signal.digVal = bool(done)
        self._joints[:] = [v * _DEG for v in joints.tolist()]
        if speed is None:
            if self._speed is not None:
                self._msg.ClearField("speedRef")
                self._speed = None
        else:
            if self._speed is None:
                self._speed = self._msg.speedRef.joints.joints
            self._speed[:] = [v * _DEG for v in speed.tolist()]
        return self._msg.SerializeToString()


def encode_sensor(seqno: int, tm: int, joints: np.ndarray, speed: np.ndarray | None,
                  done: bool = False) -> bytes:
    """An EgmSensor datagram (see :class:`SensorEncoder`)."""
    return SensorEncoder()(seqno, tm, joints, speed, done)


def decode_sensor(data: bytes, n: int) -> SensorMessage:
    """An EgmSensor datagram for an n-joint robot -> SensorMessage."""
    pb = require_egm()
    msg = _parse(pb.EgmSensor(), data, "sensor message")
    joints = list(msg.planned.joints.joints)
    if len(joints) != n:
        raise ExecutionError(f"sensor message: {len(joints)} planned joints for a {n}-joint robot")
    speed = list(msg.speedRef.joints.joints) if msg.HasField("speedRef") else []
    if speed and len(speed) != n:
        raise ExecutionError(f"sensor message: {len(speed)} speed references for a {n}-joint robot")
    return SensorMessage(int(msg.header.seqno), int(msg.header.tm), pb.EgmHeader.MessageType.Name(msg.header.mtype),
                         _joints(joints, "sensor message planned"),
                         _joints(speed, "sensor message speedRef") if speed else None,
                         bool(msg.HasField("RAPIDtoRobot") and msg.RAPIDtoRobot.digVal))
