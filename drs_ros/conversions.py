"""Pure converters between drs_model values and ROS 2 messages (no physics, no node state)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from drs_model.actuator import ActuatorState
from drs_model.inverse import REACTION_NAMES

from .errors import DRSRosError
from .recording.diagnostic_cdr import Status
from .timestamps import ns_of, seconds_from_ns, split_ns


class PastTrajectoryError(DRSRosError, ValueError):
    """A trajectory whose ``header.stamp`` puts its end before now."""


def time_msg(ns: int) -> Time:
    """builtin_interfaces/Time from integer nanoseconds (:func:`drs_ros.timestamps.split_ns`)."""
    sec, nanosec = split_ns(ns)
    return Time(sec=sec, nanosec=nanosec)


def joint_state_values(state: ActuatorState, stroke: float | None = None) -> tuple:
    """``(position, velocity, effort)`` of the node's JointState, each 3 floats, like
    ros2_control's joint_state_broadcaster: the piston (prismatic: m, m/s, effort = piston force
    N), the link and the flap (revolute: rad, rad/s, effort unknown = NaN); ``stroke`` [m]: the
    piston's position as a (faulty) sensor reports it (None: the true one)."""
    position = tuple(state.q) if stroke is None else (stroke, *state.q[1:])
    return position, tuple(state.qd), (state.piston_force, math.nan, math.nan)


def joint_state_packer(names: Sequence[str]):
    """``pack(state, stamp_ns, stroke=None) -> bytes``: the exact CDR of the JointState of
    joints ``names`` holding :func:`joint_state_values` (with its ``stroke``), stamped
    ``stamp_ns``, its numbers packed into the message's layout
    (:class:`drs_ros.recording.cdr.Layout`) without building it."""
    from .recording import cdr

    pack = cdr.Layout(
        JointState(
            name=list(names),
            position=[0.0] * 3,
            velocity=[0.0] * 3,
            effort=[0.0] * 3,
        )
    ).packer(["header.stamp.sec", "header.stamp.nanosec", "position", "velocity", "effort"])

    def pack_state(state: ActuatorState, stamp_ns: int, stroke: float | None = None) -> bytes:
        position, velocity, effort = joint_state_values(state, stroke)
        return pack(*split_ns(stamp_ns), *position, *velocity, *effort)

    return pack_state


def reactions_packer():
    """``pack(reactions, stamp_ns) -> bytes``: the exact CDR of the joint reactions as a
    JointState whose names are the reactions and efforts their values (self-describing and
    stamped ``stamp_ns``; the model's :data:`~drs_model.inverse.REACTION_NAMES`, in that order:
    N, Tp in N m), packed into the message's layout (:class:`drs_ros.recording.cdr.Layout`)."""
    from .recording import cdr

    pack = cdr.Layout(JointState(name=list(REACTION_NAMES), effort=[0.0] * len(REACTION_NAMES)))
    pack = pack.packer(["header.stamp.sec", "header.stamp.nanosec", "effort"])

    def pack_reactions(reactions: Mapping[str, float], stamp_ns: int) -> bytes:
        return pack(*split_ns(stamp_ns), *(float(reactions[k]) for k in REACTION_NAMES))

    return pack_reactions


def trajectory_points(msg, joint: str) -> tuple[list[float], list[float], list[float] | None]:
    """``(times [s from now], strokes [m], rates [m/s] or None)`` of joint ``joint`` in a
    trajectory_msgs/JointTrajectory, validated as ros2_control's joint_trajectory_controller
    validates one: unique joint names; in every point, ``positions`` as long as ``joint_names``
    and ``velocities`` / ``accelerations`` / ``effort`` empty or as long; ``time_from_start``
    strictly increasing from the second point on. A first point at 0 s followed by others (the
    sender's view of the present state, as MoveIt sends every goal) is left out: the actuator
    starts from its own state. Rates are used only when the points give them.

    Raises :class:`drs_model.errors.InputError` with the reason (the point, the field, the
    lengths).
    """
    from drs_model.errors import InputError

    names = list(msg.joint_names)
    n = len(names)
    if len(set(names)) != n:
        raise InputError(f"trajectory joint_names must be unique, got {names}")
    if joint not in names:
        raise InputError(f"trajectory must name joint {joint!r}, got joint_names {names}")
    if not msg.points:
        raise InputError("trajectory has no points")
    j = names.index(joint)
    times, strokes, rates = [], [], []
    for k, pt in enumerate(msg.points):
        if len(pt.positions) != n:
            raise InputError(
                f"trajectory point {k} has {len(pt.positions)} positions for {n} joint_names"
            )
        for field in ("velocities", "accelerations", "effort"):
            size = len(getattr(pt, field))
            if size not in (0, n):
                raise InputError(
                    f"trajectory point {k} has {size} {field} for {n} joint_names "
                    "(give none or one per joint)"
                )
        t = seconds_from_ns(ns_of(pt.time_from_start))
        if times and t <= times[-1]:
            raise InputError(
                f"trajectory time_from_start must increase strictly: point {k} at {t:g} s "
                f"follows {times[-1]:g} s"
            )
        times.append(t)
        strokes.append(float(pt.positions[j]))
        rates.append(float(pt.velocities[j]) if pt.velocities else None)
    use_rates = any(r is not None for r in rates)
    if use_rates and not all(r is not None for r in rates):
        raise InputError("trajectory velocities must be given in every point or in none")
    if len(times) > 1 and times[0] == 0.0:
        # a first point at 0 s is the state the sender saw (MoveIt's every goal): the path from
        # the actuator's own state to the next point takes its place (JTC samples it at once and
        # blends from there; a path cannot jump, so the difference is blended over segment 1)
        del times[0], strokes[0], rates[0]
    return times, strokes, (rates if use_rates else None)


def stamp_of(msg) -> int:
    """``header.stamp`` [ns] of a JointTrajectory (a message, or the node's in-place view)."""
    stamp = getattr(msg, "stamp", None)
    return ns_of(stamp if stamp is not None else msg.header.stamp)


def started_points(msg, joint: str, now_ns: int | None):
    """:func:`trajectory_points` with joint_trajectory_controller's start time: a non-zero
    ``header.stamp`` starts the trajectory then, a zero one now (``now_ns`` [ns], the node
    time the stamp is read against; None: the stamp is not read); times are returned from
    now, the points at or before now left out. Raises :class:`PastTrajectoryError` when its
    last point lies in the past (JTC refuses it)."""
    times, strokes, rates = trajectory_points(msg, joint)
    start_ns = 0 if now_ns is None else stamp_of(msg)
    if start_ns == 0:
        return times, strokes, rates
    shift = seconds_from_ns(start_ns - now_ns)
    if times[-1] + shift < 0.0:
        raise PastTrajectoryError(
            f"received a trajectory with non-zero start time that ends in "
            f"the past ({-(times[-1] + shift):.6g} s ago)"
        )
    keep = [k for k, t in enumerate(times) if t + shift > 0.0]  # points still to come
    return (
        [times[k] + shift for k in keep],
        [strokes[k] for k in keep],
        None if rates is None else [rates[k] for k in keep],
    )


def float_msg(value: float) -> Float64:
    return Float64(data=float(value))


def command_event_status(
    source: str, outcome: str, level: bytes, message: str, values: Mapping[str, object]
) -> Status:
    """The one status of a record of the effect log ``~/command_events`` (see docs/ros.md,
    "Effect record"): ``name`` the command's topic or service (or ``clock`` / ``reset``),
    ``level`` OK (accepted), WARN (refused) or STALE (superseded), ``message`` the outcome and
    reason, and key/values (``outcome`` first, then ``values``, each as ``str()`` gives it).
    A record is a DiagnosticArray stamped at the simulated instant it speaks of, holding this
    status: :func:`diagnostic_array_msg`, or packed directly by
    :func:`drs_ros.recording.diagnostic_cdr.diagnostic_array_cdr`."""
    return Status(
        level,
        source,
        f"{outcome}: {message}" if message else outcome,
        "drs",
        [("outcome", outcome), *_key_values(values)],
    )


def command_event_msg(
    stamp_ns: int,
    source: str,
    outcome: str,
    level: bytes,
    message: str,
    values: Mapping[str, object],
) -> DiagnosticArray:
    """One record of the effect log as a message (:func:`command_event_status`)."""
    return diagnostic_array_msg(
        stamp_ns, [command_event_status(source, outcome, level, message, values)]
    )


def parameter_event_msg(node_name: str, parameters: Sequence, stamp_ns: int):
    """rcl_interfaces/ParameterEvent listing ``parameters`` (rclpy ``Parameter`` objects) as new:
    what the node's parameter set is, in the form ``/parameter_events`` carries."""
    from rcl_interfaces.msg import ParameterEvent

    return ParameterEvent(
        stamp=time_msg(stamp_ns),
        node=node_name,
        new_parameters=[p.to_parameter_msg() for p in parameters],
    )


def diagnostics_status(
    node_name: str, level: bytes, message: str, values: Mapping[str, object]
) -> Status:
    """The node's status in ``/diagnostics``: named ``<node>: actuator``, with the key/values
    (each as ``str()`` gives it)."""
    return Status(level, f"{node_name}: actuator", message, "drs", _key_values(values))


def _key_values(values: Mapping[str, object]) -> list[tuple[str, str]]:
    return [(str(k), str(v)) for k, v in values.items()]


def diagnostic_array_msg(stamp_ns: int, statuses: Sequence[Status]) -> DiagnosticArray:
    """A DiagnosticArray stamped ``stamp_ns`` [ns] holding ``statuses`` as rclpy messages (the
    message :func:`drs_ros.recording.diagnostic_cdr.diagnostic_array_cdr` packs directly)."""
    arr = DiagnosticArray()
    arr.header.stamp = time_msg(stamp_ns)
    arr.status = [
        DiagnosticStatus(
            level=st.level,
            name=st.name,
            message=st.message,
            hardware_id=st.hardware_id,
            values=[KeyValue(key=k, value=v) for k, v in st.values],
        )
        for st in statuses
    ]
    return arr


#: Marker colours (r, g, b) by drawing, as in the rerun recording.
MARKER_COLORS = {
    "piston": (0.47, 0.47, 0.47),
    "link": (0.27, 0.27, 0.78),
    "flap": (0.84, 0.15, 0.16),
    "gap": (0.17, 0.63, 0.17),
    "fia_box": (0.63, 0.63, 0.63),
    "main_wing": (0.16, 0.16, 0.16),
    "pylon": (0.43, 0.43, 0.43),
    "pins": (0.0, 0.0, 0.0),
    "force": (1.0, 0.5, 0.05),
}
#: Length of the force arrow per newton [m/N]: 25 kN draws 0.25 m.
FORCE_ARROW_M_PER_N = 1e-5


def _marker(ident: int, name: str, kind: int, points, width: float, frame_id: str):
    from geometry_msgs.msg import Point
    from std_msgs.msg import ColorRGBA
    from visualization_msgs.msg import Marker

    m = Marker(ns=f"drs/{name}", id=ident, type=kind, action=Marker.ADD, frame_locked=True)
    m.header.frame_id = frame_id
    m.pose.orientation.w = 1.0
    m.scale.x = m.scale.y = m.scale.z = width
    r, g, b = MARKER_COLORS[name]
    m.color = ColorRGBA(r=r, g=g, b=b, a=1.0)
    m.points = [Point(x=float(x), y=float(y), z=0.0) for x, y in points]
    return m


class MechanismMarkers:
    """The mechanism as a visualization_msgs/MarkerArray, in the z = 0 plane of ``frame_id``.

    Built once (the still drawings' markers never change, the moving ones keep their objects):
    :meth:`msg` only moves points and restamps, since building a Marker costs ~50 us and a Point
    ~3 us. One LINE_STRIP per drawing (``still`` and the moving ``names``: drs_ros.drawing), the
    pins as a SPHERE_LIST, the piston force as an ARROW from its point of action along +y
    (:data:`FORCE_ARROW_M_PER_N`). Ids are fixed per drawing, so each message replaces the last.

    The array has two shapes (with the still markers and without), so its CDR has two layouts:
    :meth:`packer` packs a configuration's numbers straight into them, the bytes :meth:`msg`'s
    message serialises to, without moving a Point.
    """

    def __init__(self, still, moving_sizes: dict[str, int], n_pins: int, frame_id: str) -> None:
        from visualization_msgs.msg import Marker, MarkerArray

        markers = [
            _marker(i, name, Marker.LINE_STRIP, pts, 0.002, frame_id)
            for i, (name, pts) in enumerate(still.items())
        ]
        self._lines = {}
        for name, size in moving_sizes.items():
            self._lines[name] = _marker(
                len(markers), name, Marker.LINE_STRIP, [(0.0, 0.0)] * size, 0.002, frame_id
            )
            markers.append(self._lines[name])
        self._pins = _marker(
            len(markers), "pins", Marker.SPHERE_LIST, [(0.0, 0.0)] * n_pins, 0.006, frame_id
        )
        self._arrow = _marker(
            len(markers) + 1, "force", Marker.ARROW, [(0.0, 0.0)] * 2, 0.0, frame_id
        )
        # shaft diameter, head diameter, head length [m]
        self._arrow.scale.x, self._arrow.scale.y, self._arrow.scale.z = 0.003, 0.008, 0.01
        markers += [self._pins, self._arrow]
        self._all = MarkerArray(markers=markers)
        self._moving = MarkerArray(markers=markers[len(still) :])
        #: the moving drawings, in the order of their markers (the pins and the arrow follow)
        self.line_names = tuple(moving_sizes)

    def msg(
        self, lines, pins, force_origin, piston_force: float, stamp_ns: int, with_still: bool = True
    ):
        """The array for one configuration: ``lines`` name -> (k, 2), ``pins`` (n, 2) [m], the
        force [N] at ``force_origin`` (2,) [m]; every marker stamped ``stamp_ns``. Without
        ``with_still`` only the moving markers (markers live until replaced: the still ones
        drawn once stay)."""
        arrow = force_arrow(force_origin, piston_force)
        for marker, pts in [
            *((self._lines[k], v) for k, v in lines.items()),
            (self._pins, pins),
            (self._arrow, arrow),
        ]:
            for point, (px, py) in zip(marker.points, pts, strict=True):
                point.x, point.y = float(px), float(py)
        stamp = time_msg(stamp_ns)
        array = self._all if with_still else self._moving
        for marker in array.markers:
            marker.header.stamp = stamp
        return array

    def packer(self):
        """``pack(lines, pins, force_origin, piston_force, stamp_ns, with_still=True) -> bytes``:
        the exact CDR of :meth:`msg`'s array for the same arguments, without moving a Point: each
        shape's numbers (every marker's stamp, the moving markers' points) packed into its layout
        (:meth:`drs_ros.recording.cdr.Layout.packer`; the still outlines stay the template's).
        Raises :class:`~drs_ros.recording.cdr.CdrError` for a stamp beyond the int32 seconds of
        builtin_interfaces/Time, as the serialiser does."""
        import numpy as np

        from .recording import cdr

        names, n_moving = self.line_names, len(self._moving.markers)
        shapes = {
            with_still: _MarkersLayout(cdr.Layout(array), len(array.markers), n_moving)
            for with_still, array in ((True, self._all), (False, self._moving))
        }

        def pack(
            lines, pins, force_origin, piston_force: float, stamp_ns: int, with_still: bool = True
        ) -> bytes:
            stamp = split_ns(stamp_ns)
            if not -(2**31) <= stamp[0] < 2**31:
                raise cdr.CdrError(
                    f"stamp {stamp_ns!r} ns is beyond builtin_interfaces/Time's "
                    f"int32 seconds ({stamp[0]} s)"
                )
            xy = np.concatenate(
                [*(lines[k] for k in names), pins, force_arrow(force_origin, piston_force)]
            )
            xyz = np.zeros((len(xy), 3))  # the drawing's plane: z = 0
            xyz[:, :2] = xy
            return shapes[with_still].pack(stamp, xyz.ravel().tolist())

        return pack


class _MarkersLayout:
    """One shape of :class:`MechanismMarkers`' array (``n`` markers, the last ``n_moving`` of
    them moving): its layout's packer of every marker's stamp and the moving markers' points."""

    def __init__(self, layout, n: int, n_moving: int) -> None:
        paths, self.counts = [], []
        for i in range(n):
            paths += [f"markers.{i}.header.stamp.sec", f"markers.{i}.header.stamp.nanosec"]
            count = 0
            if i >= n - n_moving:
                paths.append(f"markers.{i}.points")
                count = layout.fields[paths[-1]][2]  # x, y, z of each point
            self.counts.append(count)
        self._pack = layout.packer(paths)

    def pack(self, stamp: tuple[int, int], xyz: list[float]) -> bytes:
        """The bytes for every marker stamped ``stamp`` (sec, nanosec), the moving markers'
        points ``xyz`` (x, y, z of each, in marker order)."""
        values, j = [], 0
        for count in self.counts:
            values += stamp
            values += xyz[j : j + count]
            j += count
        return self._pack(*values)


def force_arrow(force_origin, piston_force: float) -> tuple[tuple[float, float], ...]:
    """The piston force [N] drawn as an arrow from ``force_origin`` (2,) [m] along +y,
    :data:`FORCE_ARROW_M_PER_N` long per newton: its two ends [m]."""
    x, y = float(force_origin[0]), float(force_origin[1])
    return (x, y), (x, y + FORCE_ARROW_M_PER_N * float(piston_force))
