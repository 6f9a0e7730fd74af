"""drs_ros.conversions.MechanismMarkers.packer, the node's ~/markers packed into the layouts of
the array's two shapes: over configurations across the working stroke, any piston force (NaN,
+-inf and -0.0 included) and any stamp Time holds, with and without the still outlines, the
packed bytes equal the field-by-field serialiser's bytes of the message :meth:`msg` builds for
the same arguments, and rclpy's deserialiser (which shares no code with either) reads back the
drawn points, z = 0 and the stamp of every marker."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

from rclpy.serialization import deserialize_message  # noqa: E402
from visualization_msgs.msg import MarkerArray  # noqa: E402

from drs_model import kinematics as kin  # noqa: E402
from drs_ros.conversions import FORCE_ARROW_M_PER_N, MechanismMarkers  # noqa: E402
from drs_ros.drawing import moving_drawings, still_drawings  # noqa: E402
from drs_ros.recording import cdr  # noqa: E402
from drs_ros.timestamps import split_ns  # noqa: E402

#: Every stamp builtin_interfaces/Time holds from the epoch on (int32 seconds).
LAST_STAMP_NS = 2**31 * 10**9 - 1
force = st.floats(width=64) | st.sampled_from([-0.0, 0.0, math.nan, math.inf, -math.inf])
stamp = st.integers(0, LAST_STAMP_NS)


@pytest.fixture(scope="module")
def scene(params):
    """The scene as the node builds it (drs_ros.node.publishers) and its packer."""
    s_min, _ = kin.stroke_limits(params)
    lines, pins, _ = moving_drawings(np.array([[s_min, 0.0, 0.0]]), params)
    markers = MechanismMarkers(
        still_drawings(params), {k: v.shape[1] for k, v in lines.items()}, pins.shape[1], "drs_base"
    )
    return markers, markers.packer()


def _drawing(params, fraction: float):
    """The moving drawings of the configuration ``fraction`` of the way along the stroke."""
    s_min, s_max = kin.stroke_limits(params)
    q = kin.solve_position(np.array([s_min + fraction * (s_max - s_min)]), params)
    lines, pins, force_at = moving_drawings(q, params)
    return {k: v[0] for k, v in lines.items()}, pins[0], force_at[0]


@settings(max_examples=150, deadline=None)
@given(
    fraction=st.floats(0.0, 1.0),
    forces=st.lists(force, min_size=3, max_size=3),
    stamps=st.lists(stamp, min_size=3, max_size=3),
    shapes=st.lists(st.booleans(), min_size=1, max_size=3),
)
@example(fraction=0.0, forces=[-0.0, 0.0, -0.0], stamps=[0, 1, 0], shapes=[True, False])
@example(
    fraction=1.0,
    forces=[math.nan, math.inf, -math.inf],
    stamps=[LAST_STAMP_NS, 0, LAST_STAMP_NS],
    shapes=[False, True, False],
)
def test_packed_markers_are_the_serialised_message(params, scene, fraction, forces, stamps, shapes):
    """Packed one after another in either shape (each shape's buffer is reused), every array's
    bytes are those of the message."""
    markers, pack = scene
    lines, pins, force_at = _drawing(params, fraction)
    serialize = cdr.serializer(MarkerArray)
    for with_still, piston_force, stamp_ns in zip(shapes, forces, stamps, strict=False):
        packed = pack(lines, pins, force_at, piston_force, stamp_ns, with_still)
        msg = markers.msg(lines, pins, force_at, piston_force, stamp_ns, with_still=with_still)
        assert packed == serialize(msg)


@settings(max_examples=60, deadline=None)
@given(fraction=st.floats(0.0, 1.0), piston_force=force, stamp_ns=stamp, with_still=st.booleans())
def test_rclpy_reads_the_drawn_points_back(
    params, scene, fraction, piston_force, stamp_ns, with_still
):
    lines, pins, force_at = _drawing(params, fraction)
    back = deserialize_message(
        scene[1](lines, pins, force_at, piston_force, stamp_ns, with_still), MarkerArray
    )
    by_ns = {m.ns: m for m in back.markers}
    still = {f"drs/{name}" for name in still_drawings(params)}
    assert (still <= set(by_ns)) == with_still and (still & set(by_ns) == set()) != with_still
    for m in back.markers:
        assert (m.header.stamp.sec, m.header.stamp.nanosec) == split_ns(stamp_ns)
        assert m.header.frame_id == "drs_base" and all(p.z == 0.0 for p in m.points)

    def xy(name):
        return np.array([(p.x, p.y) for p in by_ns[f"drs/{name}"].points])

    for name, drawn in lines.items():
        np.testing.assert_array_equal(xy(name), drawn)
    np.testing.assert_array_equal(xy("pins"), pins)
    arrow = xy("force")
    np.testing.assert_array_equal(arrow[0], force_at)
    assert arrow[1, 0] == force_at[0]
    if math.isfinite(piston_force):
        rise = arrow[1, 1] - arrow[0, 1]
        assert rise == pytest.approx(piston_force * FORCE_ARROW_M_PER_N, abs=1e-15)
    else:
        assert not math.isfinite(arrow[1, 1])


def test_the_still_outlines_come_from_the_template(params, scene):
    """The still outlines are not packed per tick: they are in the bytes as drawn once."""
    lines, pins, force_at = _drawing(params, 0.5)
    back = deserialize_message(scene[1](lines, pins, force_at, 0.0, 0, True), MarkerArray)
    by_ns = {m.ns: m for m in back.markers}
    for name, outline in still_drawings(params).items():
        np.testing.assert_array_equal([(p.x, p.y) for p in by_ns[f"drs/{name}"].points], outline)


@pytest.mark.parametrize("stamp_ns", [-(2**31) * 10**9 - 1, 2**31 * 10**9])
def test_a_stamp_beyond_time_is_refused_and_the_next_array_is_whole(params, scene, stamp_ns):
    markers, pack = scene
    lines, pins, force_at = _drawing(params, 0.3)
    with pytest.raises(cdr.CdrError, match=r"beyond builtin_interfaces/Time's int32 seconds"):
        pack(lines, pins, force_at, 1.0, stamp_ns, True)
    msg = markers.msg(lines, pins, force_at, 1.0, 7, with_still=True)
    assert pack(lines, pins, force_at, 1.0, 7, True) == cdr.serializer(MarkerArray)(msg)
