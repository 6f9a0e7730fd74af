"""drs_ros.node.publishers: the markers of a configuration already drawn are the same bytes as a
new drawing of it, and a held flap is not drawn again."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

require_rclpy()

from rclpy.node import Node  # noqa: E402

from drs_model.kinematics import solve_position, stroke_limits  # noqa: E402
from drs_model.params import DRSParams  # noqa: E402
from drs_ros.node import publishers  # noqa: E402

NAMES = ("piston", "link", "flap")


def _publishers(node, p: DRSParams, name: str):
    return publishers.StatePublishers(
        node,
        joint_states_topic=f"/{name}/joint_states",
        joint_names=NAMES,
        frame_id="base_link",
        params=p,
        s_min=stroke_limits(p)[0],
        markers_period=1 / 30,
        hydraulic=False,
    )


def _state(p: DRSParams, s: float, t: float, force: float):
    return SimpleNamespace(q=np.asarray(solve_position(s, p), dtype=float), t=t, piston_force=force)


def test_a_held_flap_is_drawn_once_and_its_markers_are_a_new_drawing_s_bytes(
    ros_context, monkeypatch
):
    p = DRSParams()
    lo, hi = stroke_limits(p)
    node = Node("drs_markers_probe", context=ros_context)
    drawings = []
    real = publishers.moving_drawings

    def counted(q, params):
        drawings.append(np.array(q))
        return real(q, params)

    try:
        # the flap held, then moved, then back where it was; the force changes while it is held
        states = [
            _state(p, lo, 0.0, 0.0),
            _state(p, lo, 0.1, 250.0),
            _state(p, 0.5 * (lo + hi), 0.2, 900.0),
            _state(p, lo, 0.3, 0.0),
        ]
        stamps = [10**9 + k * 10**8 for k in range(len(states))]
        expected = []  # each state drawn by publishers that drew nothing before
        for k, (st, stamp) in enumerate(zip(states, stamps, strict=True)):
            fresh = _publishers(node, p, f"fresh{k}")
            fresh._last_still_t = None if k == 0 else 0.0  # the still outlines: the first only
            expected.append(fresh._markers(st, stamp))
            fresh.destroy(node)
        kept = _publishers(node, p, "kept")  # (its scene is sized by a drawing of its own)
        monkeypatch.setattr(publishers, "moving_drawings", counted)
        got = [kept._markers(st, stamp) for st, stamp in zip(states, stamps, strict=True)]
        kept.destroy(node)
        assert got == expected
        # the held flap's second state was not drawn again; back at the start it was
        assert [float(q[0, 0]) for q in drawings] == [lo, 0.5 * (lo + hi), lo]
    finally:
        node.destroy_node()
