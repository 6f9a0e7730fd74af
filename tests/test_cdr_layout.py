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
    # bytes handed out are not changed by a later pack
    first = pack(1, 1.0)
    pack(2, 2.0)
    assert deserialize_message(first, JointState).position[0] == 1.0
    with pytest.raises(
        cdr.CdrError, match="header.stamp.sec at byte 4 is not after the field before it"
    ):
        layout.packer(["position", "header.stamp.sec"])  # the order they lie in, only


@settings(max_examples=100, deadline=None)
@given(data=st.data(), n=st.integers(1, 6))
def test_any_ordered_choice_of_fields_of_repeated_blocks_packs_as_the_serialiser(data, n):
    """Repeated blocks (a TFMessage of ``n`` transforms, its frames' strings of any length
    between their numbers): any subset of its numeric fields, in the order they lie, packed from
    drawn values, gives the serialiser's bytes of the message holding those values."""
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage

    frames = data.draw(st.lists(st.tuples(name, name), min_size=n, max_size=n))
    proto = TFMessage(transforms=[TransformStamped(child_frame_id=c) for _p, c in frames])
    for t, (parent, _c) in zip(proto.transforms, frames, strict=True):
        t.header.frame_id = parent
    layout = cdr.Layout(proto)
    chosen = [p for p in layout.fields if data.draw(st.booleans())]
    values = []
    for path in chosen:
        _offset, code, count = layout.fields[path]
        if code in "iI":
            draw = st.integers(0, 2**31 - 1)
        else:
            draw = number
        values += data.draw(st.lists(draw, min_size=count, max_size=count))
    expected = TFMessage(transforms=[TransformStamped() for _ in frames])
    for t, src in zip(expected.transforms, proto.transforms, strict=True):
        t.header.frame_id, t.child_frame_id = src.header.frame_id, src.child_frame_id
    i = 0
    for path in chosen:
        count = layout.fields[path][2]
        _set_path(expected, path, values[i : i + count])
        i += count
    assert layout.packer(chosen)(*values) == serialize(expected)


def _set_path(msg, path: str, values) -> None:
    """Set the numeric field ``path`` (``transforms.1.transform.rotation``) of ``msg``."""
    *parents, last = path.split(".")
    for part in parents:
        msg = msg[int(part)] if part.isdigit() else getattr(msg, part)
    if len(values) == 1:
        setattr(msg, last, values[0])
    else:  # a flat message (a Vector3, a Quaternion): its fields in order
        target = getattr(msg, last)
        for field, v in zip(target.get_fields_and_field_types(), values, strict=True):
            setattr(target, field, v)
