"""EGM messages: ABB's egm.proto as abb-robot-client ships it (``abb_robot_client.egm.egm_pb2``).

Joints travel in degrees (ABB's convention); everything in pathmotion is radians. Decoding checks what a
foreign or damaged datagram can break: protobuf framing, required fields, the joint count, finiteness.
"""

from __future__ import annotations

from dataclasses import dataclass

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


def require_egm():
    """egm_pb2, or an error saying how to install it."""
    if egm_pb2 is None:
        raise ExecutionError(f"EGM needs abb-robot-client (ABB's egm.proto): pip install 'pathmotion[egm]' ({_MISSING})")
    return egm_pb2


@dataclass(frozen=True)
class RobotMessage:
    """A decoded EgmRobot: seqno, tm [ms], joints (n,) [rad] (feedBack), planned (n,) [rad] or None,
    motors_on, rapid_running."""

    seqno: int
    tm: int
    joints: np.ndarray
    planned: np.ndarray | None
    motors_on: bool
    rapid_running: bool


def _decode(cls, data: bytes, what: str):
    pb = require_egm()
    msg = getattr(pb, cls)()
    try:
        msg.ParseFromString(data)
    except (DecodeError, RuntimeError, ValueError) as exc:
        raise ExecutionError(f"{what}: {len(data)} bytes are not an {cls} ({exc})") from None
    if not msg.IsInitialized():
        raise ExecutionError(f"{what}: {cls} lacks required fields {msg.FindInitializationErrors()}")
    return msg


def _joints(values, what: str) -> np.ndarray:
    q = np.radians(np.asarray(list(values), float))
    if not np.all(np.isfinite(q)):
        raise ExecutionError(f"{what}: joints are not finite: {list(values)}")
    return q


def decode_robot(data: bytes) -> RobotMessage:
    """An EgmRobot datagram -> RobotMessage (ExecutionError when it is not one or carries no joints)."""
    pb = require_egm()
    msg = _decode("EgmRobot", data, "robot message")
    if not msg.HasField("header") or not msg.HasField("feedBack") or not msg.feedBack.HasField("joints") \
            or not len(msg.feedBack.joints.joints):
        raise ExecutionError("robot message: no header or no feedBack.joints (is the controller in joint mode?)")
    planned = None
    if msg.HasField("planned") and len(msg.planned.joints.joints):
        planned = _joints(msg.planned.joints.joints, "robot message planned")
    return RobotMessage(
        seqno=int(msg.header.seqno), tm=int(msg.header.tm),
        joints=_joints(msg.feedBack.joints.joints, "robot message feedBack"), planned=planned,
        motors_on=msg.HasField("motorState") and msg.motorState.state == pb.EgmMotorState.MOTORS_ON,
        rapid_running=msg.HasField("rapidExecState")
        and msg.rapidExecState.state == pb.EgmRapidCtrlExecState.RAPID_RUNNING)


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


def encode_sensor(seqno: int, tm: int, joints: np.ndarray, speed: np.ndarray | None,
                  done: bool = False) -> bytes:
    """An EgmSensor datagram: planned.joints (n,) [rad] and speedRef.joints (n,) [rad/s] when given; ``done``:
    RAPIDtoRobot.digVal, the motion is over (the RAPID program may end its EGM session)."""
    pb = require_egm()
    msg = pb.EgmSensor()
    msg.header.seqno = seqno & 0xFFFFFFFF
    msg.header.tm = int(tm) & 0xFFFFFFFF
    msg.header.mtype = pb.EgmHeader.MessageType.Value(SENSOR_MTYPE)
    msg.RAPIDtoRobot.digVal = bool(done)
    msg.planned.joints.joints.extend(np.degrees(joints).tolist())
    if speed is not None:
        msg.speedRef.joints.joints.extend(np.degrees(speed).tolist())
    return msg.SerializeToString()


def decode_sensor(data: bytes, n: int) -> SensorMessage:
    """An EgmSensor datagram for an n-joint robot -> SensorMessage."""
    pb = require_egm()
    msg = _decode("EgmSensor", data, "sensor message")
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
