"""The mechanism as a robot description (URDF) and as TF transforms, from one ``DRSParams``.

Pure functions: no rclpy, no physics. Every position comes from :mod:`drs_model.kinematics`
(its named points and body frames), every limit from the model's stroke and flap limits.

The tree (frames named after the joints, ``joint_names = [piston, link, flap]``)::

    <base_frame>                       the seed's ground frame: x rearwards, y up (z = x cross y)
    |-- <piston>  prismatic, along +y, origin A       -> <piston>_rod   (frame at P = A + (0, s))
    |   `-- <link>  revolute about z, origin B = P + (0, L1) -> <link>_bar  (RF1: angle psi1)
    |       `-- fixed, origin C = (0, L2)              -> <link>_tip
    `-- <flap>  revolute about z, origin D            -> <flap>_wing  (RF3: angle psi3)
        |-- fixed, origin C3 = (-L3, 0)                -> <flap>_pin
        `-- fixed, origin T = (d_tip - L_wing, 0)      -> <flap>_tip

**The closed loop.** The link's far end C and the flap's pin C3 are one pin: ``Phi(q) = C3 - C
= 0``. A URDF is a tree, so the loop is cut at that pin: the link and the flap each hang from the
ground by their own branch, and ``<link>_tip`` and ``<flap>_pin`` are the two halves of the cut
pin. Only the piston is actuated; ``psi1`` and ``psi3`` are the dependent coordinates that the
model solves from ``s``, and every joint state the node publishes satisfies the constraint, so
the two halves coincide (to ~1e-16 m; ``tests/test_stack_description.py``). A consumer that moves
the joints independently (a slider GUI) sees the loop open, as it would in any URDF of a closed
chain (ROS 2 has no loop-closure element; SDF's would need a second joint at C).

Inertias: ``DRSParams`` is planar and holds each body's mass, centre of mass and moment about z
(``Iz_*`` about the centre of mass); ``ixx`` and ``iyy`` play no part in the planar model and are
given equal to ``izz`` (which keeps the tensor physical: each moment at most the sum of the other
two). Visual geometry: the seed's outlines (flap, main wing, pylon, FIA box), each edge a thin box
in the z = 0 plane, the piston and the link as cylinders between their pins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

from drs_model import kinematics
from drs_model.params import FORCE_LIMIT_DEFAULT_N, DRSParams

from ..conversions import MARKER_COLORS
from ..drawing import still_drawings

#: Thickness [m] of an outline's edge boxes in the drawing plane, and their depth along z.
OUTLINE_WIDTH = 0.0015
OUTLINE_DEPTH = 0.01
#: Radius [m] of the piston rod and link cylinders.
BAR_RADIUS = 0.003
#: rpy [rad] of ``<base_frame>`` in a REP 103 vehicle frame (x forward, y left, z up): the seed's
#: x points rearwards and its y up, so its z points left. The default mount rotation.
SEED_FRAME_IN_REP103_RPY = (math.pi / 2.0, 0.0, math.pi)


@dataclass(frozen=True)
class Frames:
    """Frame (link) names of the description, from the joint names and the base frame."""

    base: str
    piston: str
    link: str
    flap: str
    link_tip: str
    flap_pin: str
    flap_tip: str

    @classmethod
    def of(cls, joint_names, base: str) -> Frames:
        piston, link, flap = joint_names
        return cls(
            base,
            f"{piston}_rod",
            f"{link}_bar",
            f"{flap}_wing",
            f"{link}_tip",
            f"{flap}_pin",
            f"{flap}_tip",
        )


@dataclass(frozen=True)
class JointLimit:
    """URDF ``<limit>``: position range [m or rad], speed [m/s or rad/s], effort [N or N m]."""

    lower: float
    upper: float
    velocity: float
    effort: float


def joint_limits(p: DRSParams, force_limit: float) -> tuple[JointLimit, JointLimit, JointLimit]:
    """Limits of ``[piston, link, flap]``.

    Positions: the stroke ``[s_min, s_max]`` (closed and open gaps), the flap's
    ``[psi3_open, psi3_closed]``, and the link's ``psi1`` over that stroke (it is monotonic in
    ``s``, so its ends are the values at ``s_min`` and ``s_max``). Speeds: the largest of each
    joint over the seed's open-hold-close manoeuvre (full stroke in ``T_opening``). Effort: the
    piston takes up to ``force_limit`` [N]; the link and flap are passive (0).
    """
    from drs_model.profile import drs_manoeuvre

    s_min, s_max = kinematics.stroke_limits(p)
    psi3_closed, psi3_open = kinematics.flap_angle_limits(p)
    ends = kinematics.solve_position(np.array([s_min, s_max]), p)
    man = drs_manoeuvre(p)
    t = np.linspace(0.0, man.t_end, 2001)
    state = kinematics.kinematic_state(*man.evaluate(t), p)
    speed = np.abs(state.qd).max(axis=0)
    psi1 = sorted(ends[:, 1])
    return (
        JointLimit(s_min, s_max, float(speed[0]), float(force_limit)),
        JointLimit(float(psi1[0]), float(psi1[1]), float(speed[1]), 0.0),
        JointLimit(psi3_open, psi3_closed, float(speed[2]), 0.0),
    )


def _local(p: DRSParams, name: str) -> tuple[float, float]:
    return kinematics.point_table(p)[name][1]


def _num(value) -> str:
    """A number as URDF text: the shortest repr that reads back to the same double."""
    return repr(float(value))


def _xyz(x: float, y: float, z: float = 0.0) -> str:
    return f"{_num(x)} {_num(y)} {_num(z)}"


def rpy_quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Quaternion ``(x, y, z, w)`` of URDF's fixed-axis roll, pitch, yaw [rad]
    (``R = Rz(yaw) Ry(pitch) Rx(roll)``)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def _z_rotation(angle: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(angle / 2.0), math.cos(angle / 2.0))


#: A transform: (parent, child, (x, y, z) [m], quaternion (x, y, z, w)).
Transform = tuple[str, str, tuple[float, float, float], tuple[float, float, float, float]]


@dataclass(frozen=True)
class JointOrigins:
    """Where each joint sits in its parent frame [m] (``kinematics.point_table``): the piston's
    at A in the base frame, the link's at B in the piston frame, the flap's at D in the base
    frame. The URDF's ``<origin>`` elements and the published transforms both come from here."""

    piston: tuple[float, float]
    link: tuple[float, float]
    flap: tuple[float, float]

    @classmethod
    def of(cls, p: DRSParams) -> JointOrigins:
        return cls(_local(p, "A"), _local(p, "B"), _local(p, "D"))


def moving_transforms(q, origins: JointOrigins, frames: Frames) -> list[Transform]:
    """The transforms of the three joints at configuration ``q = [s, psi1, psi3]``, as
    robot_state_publisher computes them from the description: each joint's origin composed with
    its motion (the piston along +y by ``s``, the link and the flap about z by ``psi1``,
    ``psi3``). Scalar arithmetic: this runs at every published joint state."""
    s, psi1, psi3 = float(q[0]), float(q[1]), float(q[2])
    (ax, ay), (bx, by), (dx, dy) = origins.piston, origins.link, origins.flap
    return [
        (frames.base, frames.piston, (ax, ay + s, 0.0), (0.0, 0.0, 0.0, 1.0)),
        (frames.piston, frames.link, (bx, by, 0.0), _z_rotation(psi1)),
        (frames.base, frames.flap, (dx, dy, 0.0), _z_rotation(psi3)),
    ]


def fixed_transforms(p: DRSParams, frames: Frames) -> list[Transform]:
    """The fixed frames: the two halves of the cut pin (C on the link, C3 on the flap) and the
    flap tip T, in their bodies' frames (``kinematics.point_table``)."""
    no_turn = (0.0, 0.0, 0.0, 1.0)
    return [
        (frames.link, frames.link_tip, (*_local(p, "C"), 0.0), no_turn),
        (frames.flap, frames.flap_pin, (*_local(p, "C3"), 0.0), no_turn),
        (frames.flap, frames.flap_tip, (*_local(p, "T"), 0.0), no_turn),
    ]


def mount_transform(mount_frame: str, base: str, xyz, rpy) -> Transform:
    """The base frame on the car: ``xyz`` [m] and ``rpy`` [rad] of ``base`` in ``mount_frame``."""
    x, y, z = (float(v) for v in xyz)
    return (mount_frame, base, (x, y, z), rpy_quaternion(*(float(v) for v in rpy)))


# ---- URDF ---------------------------------------------------------------------------------------
def _material(name: str) -> str:
    r, g, b = MARKER_COLORS[name]
    return f'<material name="drs_{name}"><color rgba="{_xyz(r, g, b)} 1.0"/></material>'


def _outline_visuals(name: str, points: np.ndarray, origin=(0.0, 0.0), angle: float = 0.0):
    """One thin box per edge of a polyline given in a frame at ``origin`` turned by ``angle``
    within the link's frame."""
    c, s = math.cos(angle), math.sin(angle)
    pts = np.asarray(points, dtype=float)
    pts = np.stack(
        [origin[0] + c * pts[:, 0] - s * pts[:, 1], origin[1] + s * pts[:, 0] + c * pts[:, 1]],
        axis=-1,
    )
    out = []
    for k, (a, b) in enumerate(zip(pts[:-1], pts[1:], strict=True)):
        length = float(np.hypot(*(b - a)))
        if length == 0.0:
            continue
        mid = 0.5 * (a + b)
        yaw = math.atan2(float(b[1] - a[1]), float(b[0] - a[0]))
        out.append(
            f'<visual name="{name}_{k}"><origin xyz="{_xyz(*mid)}" rpy="0.0 0.0 {yaw!r}"/>'
            f'<geometry><box size="{length!r} {OUTLINE_WIDTH!r} {OUTLINE_DEPTH!r}"/></geometry>'
            f"{_material(name)}</visual>"
        )
    return out


def _bar_visual(name: str, length: float) -> str:
    """A cylinder along +y from the frame origin (a cylinder's axis is z: roll by -pi/2)."""
    return (
        f'<visual name="{name}"><origin xyz="{_xyz(0.0, length / 2.0)}" '
        f'rpy="{-math.pi / 2.0!r} 0.0 0.0"/><geometry><cylinder radius="{BAR_RADIUS!r}" '
        f'length="{length!r}"/></geometry>{_material(name)}</visual>'
    )


def _inertial(mass: float, com: tuple[float, float], izz: float) -> str:
    return (
        f'<inertial><origin xyz="{_xyz(*com)}" rpy="0.0 0.0 0.0"/><mass value="{_num(mass)}"/>'
        f'<inertia ixx="{_num(izz)}" ixy="0.0" ixz="0.0" iyy="{_num(izz)}" iyz="0.0" '
        f'izz="{_num(izz)}"/>'
        "</inertial>"
    )


def _limit(lim: JointLimit) -> str:
    return (
        f'<limit lower="{_num(lim.lower)}" upper="{_num(lim.upper)}" '
        f'velocity="{_num(lim.velocity)}" effort="{_num(lim.effort)}"/>'
    )


def ros2_control_block(
    joint_names, commands_topic: str, states_topic: str, name: str = "drs"
) -> str:
    """A ``<ros2_control>`` system whose hardware is this node through ros2_control's topic
    interface (``joint_state_topic_hardware_interface/JointStateTopicSystem``, Jazzy): the piston
    takes position or effort commands, every joint reports its state (docs/ros.md)."""
    piston, link, flap = joint_names
    passive = "".join(
        f'<joint name="{j}"><state_interface name="position"/>'
        f'<state_interface name="velocity"/></joint>'
        for j in (link, flap)
    )
    return (
        f'<ros2_control name={quoteattr(name)} type="system"><hardware>'
        "<plugin>joint_state_topic_hardware_interface/JointStateTopicSystem</plugin>"
        f'<param name="joint_commands_topic">{commands_topic}</param>'
        f'<param name="joint_states_topic">{states_topic}</param>'
        "</hardware>"
        f'<joint name="{piston}"><command_interface name="position"/>'
        '<command_interface name="effort"/><state_interface name="position"/>'
        '<state_interface name="velocity"/><state_interface name="effort"/></joint>'
        f"{passive}</ros2_control>"
    )


def robot_description(
    p: DRSParams,
    joint_names=("drs_piston", "drs_link", "drs_flap"),
    base_frame: str = "drs_base",
    force_limit: float = FORCE_LIMIT_DEFAULT_N,
    ros2_control: str = "",
    robot_name: str = "drs",
) -> str:
    """The URDF of the mechanism (see the module docstring), one element per line.

    Parameters
    ----------
    p : DRSParams
        The model the node runs: geometry, masses, inertias, limits, outlines.
    joint_names : sequence of 3 str
        ``[piston, link, flap]``, as the node's ``joint_names`` (its JointState names).
    base_frame : str
        The root link: the seed's ground frame (the node's ``frame_id``).
    force_limit : float
        The piston joint's effort limit [N].
    ros2_control : str
        A ``<ros2_control>`` element to include (:func:`ros2_control_block`), or ``""``.
    """
    fr = Frames.of(joint_names, base_frame)
    origin = JointOrigins.of(p)
    lim = joint_limits(p, force_limit)
    piston, link, flap = joint_names
    still = still_drawings(p)
    pts = kinematics.point_table(p)
    off = p.d_tip - p.L_wing
    flap_outline = np.concatenate([np.asarray(p.flap_outline), np.asarray(p.flap_outline[:1])])
    lines = [
        '<?xml version="1.0"?>',
        "<!-- drs: the DRS flap actuator, generated by drs_ros.stack.description from the "
        "DRSParams the node runs. A closed loop cut at the pin C = C3: <link>_tip and "
        "<flap>_pin are its two halves, and coincide for every published joint state. -->",
        f"<robot name={quoteattr(robot_name)}>",
        f'<link name="{fr.base}">',
        *_outline_visuals("fia_box", still["fia_box"]),
        *_outline_visuals("main_wing", still["main_wing"]),
        *_outline_visuals("pylon", still["pylon"]),
        "</link>",
        f'<link name="{fr.piston}">{_inertial(p.m_pist, pts["G1"][1], p.Iz_pist)}'
        f"{_bar_visual('piston', p.L1)}</link>",
        f'<link name="{fr.link}">{_inertial(p.m_link, pts["G2"][1], p.Iz_link)}'
        f"{_bar_visual('link', p.L2)}</link>",
        f'<link name="{fr.flap}">{_inertial(p.m_wing, pts["G3"][1], p.Iz_wing)}',
        *_outline_visuals("flap", flap_outline, origin=(off, 0.0)),
        "</link>",
        f'<link name="{fr.link_tip}"/>',
        f'<link name="{fr.flap_pin}"/>',
        f'<link name="{fr.flap_tip}"/>',
        f'<joint name="{piston}" type="prismatic"><parent link="{fr.base}"/>'
        f'<child link="{fr.piston}"/><origin xyz="{_xyz(*origin.piston)}" rpy="0.0 0.0 0.0"/>'
        f'<axis xyz="0.0 1.0 0.0"/>{_limit(lim[0])}</joint>',
        f'<joint name="{link}" type="revolute"><parent link="{fr.piston}"/>'
        f'<child link="{fr.link}"/><origin xyz="{_xyz(*origin.link)}" rpy="0.0 0.0 0.0"/>'
        f'<axis xyz="0.0 0.0 1.0"/>{_limit(lim[1])}</joint>',
        f'<joint name="{flap}" type="revolute"><parent link="{fr.base}"/>'
        f'<child link="{fr.flap}"/><origin xyz="{_xyz(*origin.flap)}" rpy="0.0 0.0 0.0"/>'
        f'<axis xyz="0.0 0.0 1.0"/>{_limit(lim[2])}</joint>',
    ]
    for parent, child, xyz, _q in fixed_transforms(p, fr):
        lines.append(
            f'<joint name="{child}_joint" type="fixed"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{_xyz(*xyz)}" rpy="0.0 0.0 0.0"/>'
            "</joint>"
        )
    if ros2_control:
        lines.append(ros2_control)
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


__all__ = [
    "Frames",
    "JointLimit",
    "JointOrigins",
    "SEED_FRAME_IN_REP103_RPY",
    "Transform",
    "fixed_transforms",
    "joint_limits",
    "mount_transform",
    "moving_transforms",
    "robot_description",
    "ros2_control_block",
    "rpy_quaternion",
]
