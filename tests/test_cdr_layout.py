"""drs_ros.recording.cdr.Layout, the template the node packs its real-time messages into,
against serialisers it does not use: the bytes equal the field-by-field serialiser's for the same
message, rclpy's deserialiser reads them back to the values packed (NaN and inf included), and
they are no longer than rclpy's own serialize_message (whose buffer may carry extra bytes)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

from message_support import joint_state_msg, serialize  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from sensor_msgs.msg import FluidPressure, JointState  # noqa: E402

from drs_ros.conversions import joint_state_packer  # noqa: E402
from drs_ros.recording import cdr  # noqa: E402
from drs_ros.timestamps import split_ns  # noqa: E402

name = st.text(st.characters(codec="utf-8", exclude_characters="\0"), min_size=0, max_size=40)
number = st.floats(width=64)  # NaN and +-inf included
stamp = st.integers(0, 2**31 * 10**9 - 1)


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


@settings(max_examples=200, deadline=None)
@given(
    names=st.tuples(name, name, name),
    q=st.tuples(number, number, number),
    qd=st.tuples(number, number, number),
    force=number,
    stamp_ns=stamp,
    stroke=st.none() | number,
)
def test_packed_joint_states_equal_the_serialiser_and_read_back(
    names, q, qd, force, stamp_ns, stroke
):
    state = SimpleNamespace(q=np.array(q), qd=np.array(qd), piston_force=force)
    packed = joint_state_packer(names)(state, stamp_ns, stroke)
    msg = joint_state_msg(state, names, stamp_ns)
    if stroke is not None:
        msg.position[0] = stroke
    assert packed == serialize(msg)
    assert len(packed) <= len(serialize_message(msg))
    back = deserialize_message(packed, JointState)
    assert list(back.name) == list(names)
    assert (back.header.stamp.sec, back.header.stamp.nanosec) == split_ns(stamp_ns)
    want = [stroke if stroke is not None else q[0], *q[1:]]
    for got, exp in zip(
        [*back.position, *back.velocity, *back.effort],
        [*want, *qd, force, math.nan, math.nan],
        strict=True,
    ):
        assert _same(got, exp)


@settings(max_examples=100, deadline=None)
@given(frame=name, pressure=number, stamp_ns=stamp)
def test_a_layout_of_a_stamped_scalar_message(frame, pressure, stamp_ns):
    proto = FluidPressure()
    proto.header.frame_id = frame
    pack = cdr.Layout(proto).packer(["header.stamp.sec", "header.stamp.nanosec", "fluid_pressure"])
    packed = pack(*split_ns(stamp_ns), pressure)
    msg = FluidPressure(fluid_pressure=pressure)
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = split_ns(stamp_ns)
    assert packed == serialize(msg)
    back = deserialize_message(packed, FluidPressure)
    assert back.header.frame_id == frame and _same(back.fluid_pressure, pressure)


@settings(max_examples=50, deadline=None)
@given(n=st.integers(0, 300), values=st.data())
def test_long_and_empty_sequences_keep_their_shape(n, values):
    proto = JointState(position=[0.0] * n)
    layout = cdr.Layout(proto)
    if n == 0:  # an empty sequence holds no number to pack
        assert "position" not in layout.fields
        assert layout.template == serialize(proto)
        return
    xs = values.draw(st.lists(number, min_size=n, max_size=n))
    packed = layout.packer(["position"])(*xs)
    assert packed == serialize(JointState(position=xs))


def test_a_layout_refuses_what_it_cannot_pack():
    layout = cdr.Layout(JointState(name=["a"], position=[0.0]))
    with pytest.raises(cdr.CdrError, match=r"no numeric field \['velocity'\]"):
        layout.packer(["velocity"])  # an empty sequence in the prototype
    pack = layout.packer(["header.stamp.sec", "position"])
    with pytest.raises(cdr.CdrError, match="1 values for 2 numbers"):
        pack(1)
    with pytest.raises(cdr.CdrError, match="cannot pack"):
        pack(2**31, 0.0)  # sec is an int32
    # the buffer is reused: a later pack does not change bytes handed out before
    first = pack(1, 1.0)
    pack(2, 2.0)
    assert deserialize_message(first, JointState).position[0] == 1.0
