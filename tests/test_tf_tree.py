"""The /tf packer against two serialisers it does not use: rclpy's deserialiser reads its bytes
back to the values given, and drs_ros.recording.cdr writes the same bytes from the message."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

from message_support import serialize  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

from drs_ros.stack.tf_tree import MovingTransformsPacker, transform_msg  # noqa: E402

frame = st.text(st.characters(codec="utf-8", exclude_characters="\0"), min_size=0, max_size=13)
finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=200, deadline=None)
@given(
    pairs=st.lists(st.tuples(frame, frame), min_size=1, max_size=4),
    stamp_ns=st.integers(0, 2**31 * 10**9 - 1),
    data=st.data(),
)
def test_packed_transforms_read_back_and_equal_the_serialiser(pairs, stamp_ns, data):
    values = [data.draw(st.tuples(*[finite] * 7)) for _ in pairs]
    packed = MovingTransformsPacker(pairs).pack(stamp_ns, values)
    msg = TFMessage(
        transforms=[
            transform_msg((p, c, v[:3], v[3:]), stamp_ns)
            for (p, c), v in zip(pairs, values, strict=True)
        ]
    )
    assert packed == serialize(msg)
    back = deserialize_message(packed, TFMessage)
    assert len(back.transforms) == len(pairs)
    for t, (parent, child), v in zip(back.transforms, pairs, values, strict=True):
        assert (t.header.frame_id, t.child_frame_id) == (parent, child)
        assert t.header.stamp.sec * 10**9 + t.header.stamp.nanosec == stamp_ns
        tr, rot = t.transform.translation, t.transform.rotation
        assert (tr.x, tr.y, tr.z, rot.x, rot.y, rot.z, rot.w) == v  # exact: doubles both ways


def test_a_wrong_number_of_transforms_is_refused():
    packer = MovingTransformsPacker([("a", "b"), ("b", "c")])
    with pytest.raises(ValueError):
        packer.pack(0, [(0.0,) * 7])
    # numbers moved from one transform to the next (6 + 8) are refused too, not shifted
    for lengths in ((6, 8), (8, 6), (7, 8), (7, 6)):
        with pytest.raises(ValueError, match=r"2 transforms of 7 numbers each are packed, got"):
            packer.pack(0, [(0.0,) * n for n in lengths])
