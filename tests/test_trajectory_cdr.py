"""The in-place JointTrajectory reader against rclpy's decoder (an independent implementation):
the same points, the same refusals, and never a message that rclpy would not decode exactly."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

from builtin_interfaces.msg import Duration  # noqa: E402
from message_support import serialize  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

from drs_model.errors import InputError  # noqa: E402
from drs_ros.conversions import trajectory_points  # noqa: E402
from drs_ros.node.trajectory_cdr import read_joint_trajectory  # noqa: E402
from drs_ros.recording import cdr, cdr_received  # noqa: E402

NAMES = st.lists(
    st.sampled_from(["drs_piston", "drs_link", "drs_flap", "other", "é"]), min_size=0, max_size=4
)
FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64)


@st.composite
def trajectories(draw) -> JointTrajectory:
    names = draw(NAMES)
    msg = JointTrajectory(joint_names=names)
    # a ROS string is UTF-8 without NUL: no surrogate, which no UTF-8 encodes (one drawn,
    # '\ud800', failed the serialiser, not the reader)
    text = st.characters(codec="utf-8", exclude_characters="\0")
    msg.header.frame_id = draw(st.text(text, max_size=5))
    n = len(names)
    for _ in range(draw(st.integers(0, 6))):
        size = draw(st.sampled_from([n, n, n, 0, n + 1]))
        pt = JointTrajectoryPoint(positions=draw(st.lists(FLOATS, min_size=size, max_size=size)))
        for field in ("velocities", "accelerations", "effort"):
            k = draw(st.sampled_from([0, n, 1]))
            setattr(pt, field, draw(st.lists(FLOATS, min_size=k, max_size=k)))
        pt.time_from_start = Duration(
            sec=draw(st.integers(0, 3)), nanosec=draw(st.integers(0, 999_999_999))
        )
        msg.points.append(pt)
    return msg


def outcome(msg, joint="drs_piston"):
    """trajectory_points' result, or the refusal's message."""
    try:
        return trajectory_points(msg, joint)
    except InputError as exc:
        return f"refused: {exc}"


def same(a, b) -> bool:
    """Equal, NaN equal to NaN."""
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    flat = [
        (x, y)
        for u, v in zip(a, b, strict=True)
        if u is not None or v is not None
        for x, y in zip(u, v, strict=True)
    ]
    return all(x == y or (x != x and y != y) for x, y in flat) and len(a) == len(b)


@settings(max_examples=300, deadline=None)
@given(trajectories())
def test_the_reader_sees_what_rclpy_decodes(msg):
    data = serialize(msg)
    view = read_joint_trajectory(data)
    decoded = deserialize_message(data, JointTrajectory)
    assert view.joint_names == list(decoded.joint_names)
    assert view.frame_id == decoded.header.frame_id
    assert len(view.points) == len(decoded.points)
    assert same(outcome(view), outcome(decoded))
    # with the transport's padding too
    assert same(outcome(read_joint_trajectory(data + b"\0" * (-len(data) % 4))), outcome(decoded))


@settings(max_examples=300, deadline=None)
@given(trajectories(), st.data())
def test_what_the_reader_accepts_rclpy_decodes_exactly(msg, data):
    """Damaged bytes (cut, extended, one byte changed): if the reader takes them, rclpy decodes
    them too, to the same trajectory, and the view's exact CDR is the decoded message's (a
    changed alignment-padding byte is taken, and zeroed in what is recorded)."""
    raw = bytearray(serialize(msg))
    how = data.draw(st.sampled_from(["cut", "extend", "flip"]))
    if how == "cut":
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
    elif how == "extend":
        raw += bytes(data.draw(st.lists(st.integers(0, 255), min_size=1, max_size=6)))
    else:
        raw[data.draw(st.integers(0, len(raw) - 1))] ^= data.draw(st.integers(1, 255))
    try:
        view = read_joint_trajectory(bytes(raw))
    except cdr.CdrError:
        return
    decoded, exact = cdr_received.decode_exact(
        bytes(raw), JointTrajectory
    )  # raises if rclpy cannot
    assert view.exact == exact  # what the node records: the exact CDR of what rclpy decodes
    assert same(outcome(view), outcome(decoded))


@pytest.mark.parametrize(
    "data, why",
    [
        (b"", "do not start with"),
        (b"\x00\x00\x00\x00" + b"\x00" * 16, "do not start with"),  # big-endian
        (b"\x00\x01\x00\x00\x01", "needs 8 bytes"),
        (b"\x00\x01\x00\x00" + b"\x00" * 8 + b"\xff\xff\xff\x7f", "needs"),
    ],
)
def test_malformed_bytes_are_refused_with_the_place(data, why):
    with pytest.raises(cdr.CdrError, match=why):
        read_joint_trajectory(data)


def test_alignment_padding_of_any_content_is_taken_and_zeroed():
    """Fast DDS leaves alignment padding uninitialised in what rclpy publishers send."""
    msg = JointTrajectory(joint_names=["drs_piston"])
    msg.points = [JointTrajectoryPoint(positions=[0.01], time_from_start=Duration(sec=1))]
    exact = serialize(msg)
    view = read_joint_trajectory(exact)
    # the 4 bytes between the positions count and its first double are padding
    count_at = 4 + len(exact) - 4 - 8 - 3 * 4 - 8 - 4 - 4
    dirty = bytearray(exact)
    dirty[count_at + 4 : count_at + 8] = b"\xde\xad\xbe\xef"
    assert bytes(dirty) != exact
    again = read_joint_trajectory(bytes(dirty))
    assert again.exact == exact == view.exact
    assert trajectory_points(again, "drs_piston") == trajectory_points(view, "drs_piston")
