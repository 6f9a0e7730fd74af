"""The CDR engine (drs_ros.recording.cdr) against rclpy's own serialiser, an independent
implementation (Fast CDR, in C++), for every message type the node publishes or records.

rclpy's ``serialize_message`` is not exact with the Jazzy wheels: its buffer may run past the
data and its alignment padding is uninitialised memory. So the bytes are compared where rclpy's
are defined: every byte where the two differ must be one the engine wrote as zero padding, and
rclpy's decoder must read both to the message drawn (bit for bit: NaN payloads, -0.0), while one
byte fewer than the engine wrote does not decode (no byte too many). The engine's own decoders
(``decode_exact``, the in-place trajectory reader) must give back the exact bytes and the message,
from rclpy's bytes too (their padding dirty).
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ros_support import JOINT_NAMES, require_rclpy

from drs_model.inverse import REACTION_NAMES

require_rclpy()

from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from geometry_msgs.msg import TransformStamped  # noqa: E402
from rcl_interfaces.msg import ParameterEvent  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from rosidl_parser.definition import (  # noqa: E402
    AbstractNestedType,
    AbstractSequence,
    AbstractString,
    Array,
    BasicType,
    BoundedSequence,
    BoundedString,
    NamespacedType,
)
from sensor_msgs.msg import FluidPressure, JointState  # noqa: E402
from std_msgs.msg import Float64, String  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402
from trajectory_msgs.msg import JointTrajectory  # noqa: E402
from visualization_msgs.msg import MarkerArray  # noqa: E402

from drs_ros.conversions import joint_state_packer, reactions_packer, time_msg  # noqa: E402
from drs_ros.node.trajectory_cdr import read_joint_trajectory  # noqa: E402
from drs_ros.recording import cdr, cdr_received, msgdefs  # noqa: E402
from drs_ros.stack.tf_tree import MovingTransformsPacker  # noqa: E402
from drs_ros.timestamps import split_ns  # noqa: E402

#: What the node publishes (drs_ros.node.publishers, drs_ros.stack.tf_tree) and records (the
#: commands it receives, its service's events, its parameters) through the engine.
NODE_TYPES = [
    JointState,
    Float64,
    FluidPressure,
    DiagnosticArray,
    MarkerArray,
    TFMessage,
    String,
    JointTrajectory,
    SetBool.Event,
    ParameterEvent,
]

#: The largest float32 rclpy takes: the one below FLT_MAX.
FLOAT32_BELOW_MAX = float(np.nextafter(np.finfo(np.float32).max, np.float32(0)))
INT_BOUNDS = {"int8": 8, "int16": 16, "int32": 32, "int64": 64}
TEXT = st.characters(codec="utf-8", exclude_characters="\0")  # any code point, non-ASCII too
#: Time stamps [ns] over the whole range of builtin_interfaces/Time (int32 sec, uint32 nanosec).
STAMP_NS = st.integers(-(2**31) * 10**9, 2**31 * 10**9 - 1)


def _basic(typename: str):
    if typename == "double":
        return st.floats(width=64)  # NaN, +-inf, -0.0, subnormals
    if typename == "float":  # rclpy refuses FLT_MAX itself (its bound is 3.402823466e38)
        return st.floats(-FLOAT32_BELOW_MAX, FLOAT32_BELOW_MAX, width=32) | st.sampled_from(
            [math.inf, -math.inf, math.nan, -0.0]
        )
    if typename == "boolean":
        return st.booleans()
    if typename == "octet":
        return st.binary(min_size=1, max_size=1)
    if typename == "char":
        return st.characters(max_codepoint=127)
    if typename in INT_BOUNDS:
        bits = INT_BOUNDS[typename]
        return st.integers(-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
    return st.integers(0, 2 ** INT_BOUNDS["int" + typename.removeprefix("uint")] - 1)


def _value(typ, depth: int):
    """A strategy for one value of rosidl type ``typ``; sequences are short or long (up to 300
    primitives, up to 3 nested messages, nested at most 3 deep)."""
    if isinstance(typ, BasicType):
        return _basic(typ.typename)
    if isinstance(typ, AbstractString):
        limit = typ.maximum_size if isinstance(typ, BoundedString) else 600
        return st.text(TEXT, max_size=8) | st.text(TEXT, min_size=min(100, limit), max_size=limit)
    if isinstance(typ, NamespacedType):
        return messages(_class(typ), depth + 1)
    assert isinstance(typ, AbstractNestedType), typ
    element = _value(typ.value_type, depth)
    if isinstance(typ, Array):
        return st.lists(element, min_size=typ.size, max_size=typ.size)
    assert isinstance(typ, AbstractSequence), typ
    if isinstance(typ.value_type, NamespacedType):
        longest = 0 if depth >= 3 else 3
    else:
        longest = 300
    if isinstance(typ, BoundedSequence):
        longest = min(longest, typ.maximum_size)
    return st.lists(element, max_size=min(longest, 4)) | st.lists(element, max_size=longest)


def _class(typ: NamespacedType) -> type:
    return msgdefs.message_class("/".join([*typ.namespaces, typ.name]))


def messages(cls: type, depth: int = 0):
    """Any message of ``cls``, from its rosidl introspection (every field drawn)."""
    fields = list(cls.get_fields_and_field_types())
    values = [_value(typ, depth) for typ in cls.SLOT_TYPES]
    return st.tuples(*values).map(lambda vs: cls(**dict(zip(fields, vs, strict=True))))


def canonical(value):
    """A message's value as nested tuples, floats by their bits (NaN equal to the same NaN)."""
    if isinstance(value, np.generic):
        value = value.item()
    if hasattr(value, "get_fields_and_field_types"):
        return tuple(canonical(getattr(value, f)) for f in value.get_fields_and_field_types())
    if isinstance(value, float):
        return struct.pack("<d", value)
    if isinstance(value, (str, bytes, int)):
        return value
    return tuple(canonical(v) for v in value)


def assert_rclpy_agrees(packed: bytes, msg) -> None:
    """``packed`` is rclpy's serialisation of ``msg`` wherever rclpy's bytes are defined."""
    cls = type(msg)
    wire = serialize_message(msg)
    assert len(wire) >= len(packed), (len(wire), len(packed))
    differ = [k for k in range(len(packed)) if wire[k] != packed[k]]
    assert not [k for k in differ if packed[k]], f"bytes {differ} differ from rclpy's"
    want = canonical(msg)
    # the bytes that differ are padding rclpy's decoder skips: both decode to the message drawn
    assert canonical(deserialize_message(wire, cls)) == want
    assert canonical(deserialize_message(packed, cls)) == want
    with pytest.raises(Exception):  # noqa: B017, PT011 - rmw's error type: any refusal will do
        deserialize_message(packed[:-1], cls)
    # the engine's decoder: the exact bytes again, from the transport-padded bytes and from
    # rclpy's (dirty padding)
    decoded, exact = cdr_received.decode_exact(packed + bytes(-len(packed) % 4), cls)
    assert exact == packed and canonical(decoded) == want
    assert cdr_received.decode_exact(wire[: len(packed)], cls)[1] == packed


SLOW = settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@SLOW
@pytest.mark.parametrize("cls", NODE_TYPES, ids=lambda c: c.__qualname__)
@given(data=st.data())
def test_the_serialiser_writes_what_rclpy_writes(cls, data):
    msg = data.draw(messages(cls))
    packed = cdr.serializer(cls)(msg)
    assert_rclpy_agrees(packed, msg)
    if cls is JointTrajectory:  # the node reads trajectory commands in place
        wire = serialize_message(msg)
        assert read_joint_trajectory(wire[: len(packed)]).exact == packed


NUMBER = st.floats(width=64)
NAME = st.text(TEXT, max_size=8) | st.text(TEXT, min_size=100, max_size=400)


@SLOW
@given(
    names=st.tuples(NAME, NAME, NAME),
    numbers=st.lists(NUMBER, min_size=7, max_size=7),
    stamp_ns=STAMP_NS,
    stroke=st.none() | NUMBER,
)
def test_the_packed_joint_states_are_rclpy_s(names, numbers, stamp_ns, stroke):
    from types import SimpleNamespace

    state = SimpleNamespace(
        q=np.array(numbers[:3]), qd=np.array(numbers[3:6]), piston_force=numbers[6]
    )
    msg = JointState(
        name=list(names),
        header=_header(stamp_ns, ""),
        position=[numbers[0] if stroke is None else stroke, *numbers[1:3]],
        velocity=numbers[3:6],
        effort=[numbers[6], math.nan, math.nan],
    )
    assert_rclpy_agrees(joint_state_packer(names)(state, stamp_ns, stroke), msg)


@SLOW
@given(
    values=st.lists(NUMBER, min_size=len(REACTION_NAMES), max_size=len(REACTION_NAMES)),
    stamp_ns=STAMP_NS,
)
def test_the_packed_reactions_are_rclpy_s(values, stamp_ns):
    msg = JointState(header=_header(stamp_ns, ""), name=list(REACTION_NAMES), effort=values)
    reactions = dict(zip(REACTION_NAMES, values, strict=True))
    assert_rclpy_agrees(reactions_packer()(reactions, stamp_ns), msg)


def _header(stamp_ns: int, frame_id: str):
    from std_msgs.msg import Header

    return Header(stamp=time_msg(stamp_ns), frame_id=frame_id)


@SLOW
@given(value=NUMBER, frame=NAME, stamp_ns=STAMP_NS)
def test_the_packed_scalars_and_pressures_are_rclpy_s(value, frame, stamp_ns):
    assert_rclpy_agrees(cdr.flat_packer(Float64)(value), Float64(data=value))
    # as drs_ros.node.publishers lays out the hydraulic rung's pressures
    pack = cdr.Layout(FluidPressure(header=_header(0, frame))).packer(
        ["header.stamp.sec", "header.stamp.nanosec", "fluid_pressure"]
    )
    msg = FluidPressure(header=_header(stamp_ns, frame), fluid_pressure=value)
    assert_rclpy_agrees(pack(*split_ns(stamp_ns), value), msg)


@SLOW
@given(
    frames=st.lists(st.tuples(NAME, NAME), min_size=1, max_size=4),
    data=st.data(),
    stamp_ns=STAMP_NS,
)
def test_the_packed_transforms_are_rclpy_s(frames, data, stamp_ns):
    values = data.draw(
        st.lists(
            st.lists(NUMBER, min_size=7, max_size=7), min_size=len(frames), max_size=len(frames)
        )
    )
    msg = TFMessage(transforms=[])
    for (parent, child), v in zip(frames, values, strict=True):
        t = TransformStamped(header=_header(stamp_ns, parent), child_frame_id=child)
        tr, rot = t.transform.translation, t.transform.rotation
        tr.x, tr.y, tr.z, rot.x, rot.y, rot.z, rot.w = v
        msg.transforms.append(t)
    assert_rclpy_agrees(MovingTransformsPacker(frames).pack(stamp_ns, values), msg)


def test_the_comparison_catches_a_wrong_alignment(monkeypatch):
    """Padding counted from the start of the bytes (the header included) instead of from the end
    of the header: the check above must refuse what the engine then writes."""
    msg = JointState(name=list(JOINT_NAMES), position=[0.01, 0.2, 0.3])
    msg.header.frame_id = "odd"
    assert_rclpy_agrees(cdr.serializer(JointState)(msg), msg)
    monkeypatch.setattr(cdr, "padding", lambda offset, size: -offset % size)
    with pytest.raises(AssertionError):
        assert_rclpy_agrees(cdr.serializer(JointState)(msg), msg)
