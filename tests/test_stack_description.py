"""The robot description (URDF) of the mechanism, read by an independent parser (yourdfpy):
its joints and limits are the model's, its kinematics put every frame where drs_model.kinematics
puts the point, and its two halves of the cut loop coincide. No DDS."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from ros_support import require_module

from drs_model import kinematics as kin
from drs_model.params import DRSParams
from drs_model.profile import drs_manoeuvre

yourdfpy = require_module("yourdfpy")
description = require_module("drs_ros.stack.description")

NAMES = ("drs_piston", "drs_link", "drs_flap")


def load(xml: str):
    return yourdfpy.URDF.load(io.StringIO(xml), load_meshes=False, build_scene_graph=True)


@pytest.fixture(scope="module")
def urdf(params):
    return load(description.robot_description(params, NAMES, "drs_base", 2.0e4))


def test_joints_and_limits_are_the_models(urdf, params):
    joints = {j.name: j for j in urdf.robot.joints}
    assert urdf.base_link == "drs_base"
    assert list(urdf.actuated_joint_names) == list(NAMES)
    assert [joints[n].type for n in NAMES] == ["prismatic", "revolute", "revolute"]
    s_min, s_max = kin.stroke_limits(params)
    psi3_closed, psi3_open = kin.flap_angle_limits(params)
    piston, link, flap = (joints[n].limit for n in NAMES)
    assert (piston.lower, piston.upper) == (s_min, s_max)  # exact: the text is the repr
    assert (flap.lower, flap.upper) == (psi3_open, psi3_closed)
    q_ends = kin.solve_position(np.array([s_min, s_max]), params)
    assert (link.lower, link.upper) == (q_ends[0, 1], q_ends[1, 1])
    # psi1 is monotonic over the stroke, so the ends bound it (a dense scan finds nothing wider)
    q = kin.solve_position(np.linspace(s_min, s_max, 5001), params)
    assert q[:, 1].min() >= link.lower and q[:, 1].max() <= link.upper
    assert piston.effort == 2.0e4 and link.effort == flap.effort == 0.0
    # speed limits: the largest joint rates of the seed's manoeuvre, recomputed here
    man = drs_manoeuvre(params)
    t = np.linspace(0.0, man.t_end, 20001)
    qd = kin.kinematic_state(*man.evaluate(t), params).qd
    for lim, peak in zip((piston, link, flap), np.abs(qd).max(axis=0), strict=True):
        assert lim.velocity == pytest.approx(peak, rel=1e-4)
    assert np.allclose(joints["drs_piston"].axis, [0, 1, 0])
    assert np.allclose(joints["drs_link"].axis, [0, 0, 1])


def test_inertias_are_drsparams(urdf, params):
    links = {lk.name: lk for lk in urdf.robot.links}
    table = kin.point_table(params)
    for link, mass, com, izz in (
        ("drs_piston_rod", params.m_pist, table["G1"][1], params.Iz_pist),
        ("drs_link_bar", params.m_link, table["G2"][1], params.Iz_link),
        ("drs_flap_wing", params.m_wing, table["G3"][1], params.Iz_wing),
    ):
        inertial = links[link].inertial
        assert inertial.mass == mass
        assert np.allclose(inertial.origin[:2, 3], com, rtol=0, atol=1e-15)
        assert inertial.inertia[2, 2] == izz
        assert np.allclose(inertial.inertia, np.diag([izz] * 3))


@pytest.mark.parametrize("frac", [0.0, 0.13, 0.5, 0.87, 1.0])
def test_frames_sit_where_kinematics_puts_the_points(urdf, params, frac):
    s_min, s_max = kin.stroke_limits(params)
    q = kin.solve_position(s_min + frac * (s_max - s_min), params)
    urdf.update_cfg(dict(zip(NAMES, q, strict=True)))
    pts = kin.point_positions(q, params)
    for frame, point in (
        ("drs_piston_rod", "P"),
        ("drs_link_bar", "B"),
        ("drs_flap_wing", "D"),
        ("drs_flap_pin", "C3"),
        ("drs_link_tip", "C"),
        ("drs_flap_tip", "T"),
    ):
        where = urdf.get_transform(frame, "drs_base")[:3, 3]
        assert np.abs(where - [*pts[point], 0.0]).max() < 1e-12, (frame, where, pts[point])
    # the loop cut at the pin: both halves in one place (the model's constraint holds)
    tip = urdf.get_transform("drs_link_tip", "drs_base")[:3, 3]
    pin = urdf.get_transform("drs_flap_pin", "drs_base")[:3, 3]
    assert np.abs(tip - pin).max() < 1e-12
    # the frames turn with the bodies: the flap frame's x axis is (cos psi3, sin psi3)
    rot = urdf.get_transform("drs_flap_wing", "drs_base")[:3, :3]
    assert np.allclose(rot[:2, 0], [math.cos(q[2]), math.sin(q[2])], atol=1e-15)


def test_names_follow_joint_names_and_the_base_frame(params):
    names = ("piston_a", "link_a", "flap_a")
    urdf = load(description.robot_description(params, names, "rear_drs", 1.0e4))
    assert urdf.base_link == "rear_drs"
    assert list(urdf.actuated_joint_names) == list(names)
    assert {"piston_a_rod", "link_a_bar", "flap_a_wing", "flap_a_pin"} <= set(urdf.link_map)


def test_changed_parameters_change_the_description():
    p = DRSParams(L3=0.101, m_wing=2.5)
    urdf = load(description.robot_description(p, NAMES, "drs_base"))
    joints = {j.name: j for j in urdf.robot.joints}
    assert joints["drs_piston"].limit.upper == kin.stroke_limits(p)[1]
    assert {lk.name: lk for lk in urdf.robot.links}["drs_flap_wing"].inertial.mass == 2.5
    assert np.allclose(joints["drs_flap_pin_joint"].origin[:3, 3], [-0.101, 0, 0])


def test_visuals_are_the_seeds_outlines(urdf, params):
    """Each outline edge is one box from point to point (the flap's in the flap frame)."""
    flap = {lk.name: lk for lk in urdf.robot.links}["drs_flap_wing"]
    boxes = [v for v in flap.visuals if v.name.startswith("flap_")]
    outline = np.asarray(params.flap_outline) + [params.d_tip - params.L_wing, 0.0]
    closed = np.concatenate([outline, outline[:1]])
    assert len(boxes) == len(closed) - 1
    for box, a, b in zip(boxes, closed[:-1], closed[1:], strict=True):
        assert box.geometry.box.size[0] == pytest.approx(np.hypot(*(b - a)), rel=1e-12)
        assert np.allclose(box.origin[:2, 3], (a + b) / 2, atol=1e-15)


def test_mount_rotation_puts_the_seed_frame_upright():
    """Default mount: the seed's x (rearwards) is REP 103's -x, its y (up) is +z."""
    x, y, z, w = description.rpy_quaternion(*description.SEED_FRAME_IN_REP103_RPY)
    rot = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    assert np.allclose(rot @ [1, 0, 0], [-1, 0, 0], atol=1e-15)
    assert np.allclose(rot @ [0, 1, 0], [0, 0, 1], atol=1e-15)
    assert np.allclose(rot @ [0, 0, 1], [0, 1, 0], atol=1e-15)  # left


def test_ros2_control_block_names_the_topic_system(params):
    block = description.ros2_control_block(NAMES, "/drs/joint_commands", "/drs/joint_states")
    xml = description.robot_description(params, NAMES, "drs_base", ros2_control=block)
    load(xml)  # still a valid URDF
    from xml.etree import ElementTree as ET

    control = ET.fromstring(xml).find("ros2_control")
    hw = control.find("hardware")
    assert hw.find("plugin").text == "joint_state_topic_hardware_interface/JointStateTopicSystem"
    params_ = {p.get("name"): p.text for p in hw.findall("param")}
    assert params_ == {
        "joint_commands_topic": "/drs/joint_commands",
        "joint_states_topic": "/drs/joint_states",
    }
    joints = {j.get("name"): j for j in control.findall("joint")}
    assert list(joints) == list(NAMES)
    cmds = [c.get("name") for c in joints["drs_piston"].findall("command_interface")]
    assert cmds == ["position", "effort"]
    assert not joints["drs_flap"].findall("command_interface")
