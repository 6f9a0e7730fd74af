"""The node's own publishers and the messages of each published state: a part of
:class:`drs_ros.node.adapter.DRSNode`, constructed with what it needs, owning its publishers,
its serialisers, the marker scene and what it last drew.

Every message is serialised once (:mod:`drs_ros.recording.cdr`; the joint states, the
reactions, the pressures and the markers packed into their layouts,
:class:`~drs_ros.recording.cdr.Layout`),
published as those bytes and handed back to the node to record as the same bytes. An optional
topic (``~/joint_reactions``, ``~/markers``) is computed only while someone listens (asked every
:data:`LISTENER_CHECK_TICKS` ticks) or, for the markers, while the bag records them; a state
message is handed to DDS only while its topic has a subscriber (the bag records it either way):
a new subscriber gets the states from at most :data:`LISTENER_CHECK_TICKS` ticks after it
matched.
"""

from __future__ import annotations

import math

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile
from sensor_msgs.msg import FluidPressure, JointState
from std_msgs.msg import Float64
from visualization_msgs.msg import MarkerArray

from ..conversions import MechanismMarkers, joint_state_packer, reactions_packer
from ..drawing import moving_drawings, still_drawings
from ..publishing import LISTENER_CHECK_TICKS, create_publisher
from ..recording import cdr
from ..timestamps import split_ns

QOS_DEPTH = 10
#: The effect record's queue: a burst of records (a flood of refused commands) is kept whole.
EVENTS_QOS_DEPTH = 100
#: The still outlines (FIA box, main wing, pylon) are in ~/markers once per this [s] of sim time.
STILL_MARKERS_PERIOD_S = 1.0

#: The hydraulic rung's topics (under the node's name): chamber pressures, supply, spool.
HYDRAULIC_TOPICS = (
    ("pressure_piston_side", FluidPressure),
    ("pressure_rod_side", FluidPressure),
    ("supply_pressure", FluidPressure),
    ("valve_spool", Float64),
)


class StatePublishers:
    """The node's publishers: the joint states, the scalar topics, the reactions, the markers,
    diagnostics, the effect record and (``hydraulic``) the hydraulic rung's topics.

    Parameters
    ----------
    node : rclpy.node.Node
        Where the publishers are created.
    joint_states_topic, joint_names, frame_id
        The node's parameters of the same names.
    params : drs_model.params.DRSParams
        The mechanism drawn on ``~/markers``.
    s_min : float
        The closed stroke [m] (the markers' first drawing sizes the scene).
    markers_period : float
        Least simulated time [s] between two ``~/markers`` messages.
    hydraulic : bool
        Create the hydraulic rung's topics (its rung, or ``fidelity: auto``).
    """

    def __init__(
        self,
        node,
        *,
        joint_states_topic: str,
        joint_names,
        frame_id: str,
        params,
        s_min: float,
        markers_period: float,
        hydraulic: bool,
    ) -> None:
        qos = QoSProfile(depth=QOS_DEPTH)

        def make(msg_type, topic, qos):
            return create_publisher(node, msg_type, topic, qos)

        self.joints = make(JointState, joint_states_topic, qos)
        self.force = make(Float64, "~/piston_force", qos)
        self.gap = make(Float64, "~/flap_gap", qos)
        # JointState has no acceleration field; with it a bag replays the piston force exactly
        self.accel = make(Float64, "~/piston_acceleration", qos)
        self.reactions = make(JointState, "~/joint_reactions", qos)
        self.markers = make(MarkerArray, "~/markers", qos)
        self.diagnostics = make(DiagnosticArray, "/diagnostics", qos)
        self.events = make(DiagnosticArray, "~/command_events", QoSProfile(depth=EVENTS_QOS_DEPTH))
        # the hydraulic rung's chamber pressures, supply pressure and valve spool
        self.hydraulic = ()
        if hydraulic:
            self.hydraulic = tuple(
                make(msg_type, f"~/{name}", qos) for name, msg_type in HYDRAULIC_TOPICS
            )
        self.all = (
            self.joints,
            self.force,
            self.gap,
            self.accel,
            self.reactions,
            self.markers,
            self.diagnostics,
            self.events,
            *self.hydraulic,
        )
        # resolved names (e.g. /drs/piston_force), fixed for the node's life: the recording keys
        self.topics = {pub: pub.topic_name for pub in self.all}
        self.frame_id, self.params, self.markers_period = frame_id, params, markers_period
        self._pack_float64 = cdr.flat_packer(Float64)
        # the joint states, the reactions and the pressures: numbers packed into their layouts
        self._pack_joint_state = joint_state_packer(joint_names)
        self._pack_reactions = reactions_packer()
        pressure = FluidPressure()
        pressure.header.frame_id = frame_id
        self._pack_pressure = cdr.Layout(pressure).packer(
            ["header.stamp.sec", "header.stamp.nanosec", "fluid_pressure"]
        )
        lines, pins, _ = moving_drawings(np.array([[s_min, 0.0, 0.0]]), params)
        self._scene = MechanismMarkers(
            still_drawings(params),
            {k: v.shape[1] for k, v in lines.items()},
            pins.shape[1],
            frame_id,
        )
        # the markers' numbers packed into the layouts of the array's two shapes
        self._pack_markers = self._scene.packer()
        #: The publishers of the states, and whether each had a subscriber at the last check
        #: (a message no one would receive is not handed to DDS: ~5-10 us each).
        self.state_publishers = tuple(
            pub for pub in self.all if pub not in (self.diagnostics, self.events)
        )
        self.listened = dict.fromkeys(self.state_publishers, False)
        #: Simulated time [s] of the last ~/markers drawn (None: never drawn).
        self.last_markers_t: float | None = None
        #: The last configuration drawn (its bytes) and its drawing (None: none yet).
        self._drawn: tuple | None = None
        self._last_still_t: float | None = None

    # ---- what the node asks --------------------------------------------------------------------
    def topic_names(self) -> dict[str, str]:
        """Role (of :data:`drs_ros.names.NODE_TOPICS`) -> the name it resolved to."""
        publishers = {
            "joint_states": self.joints,
            "piston_force": self.force,
            "flap_gap": self.gap,
            "piston_acceleration": self.accel,
            "joint_reactions": self.reactions,
            "markers": self.markers,
            "diagnostics": self.diagnostics,
            "command_events": self.events,
        }
        names = {role: pub.topic_name for role, pub in publishers.items()}
        names.update(
            (role, pub.topic_name)
            for (role, _type), pub in zip(HYDRAULIC_TOPICS, self.hydraulic, strict=False)
        )
        return names

    def recorded_topics(self) -> list[tuple[str, type, QoSProfile]]:
        """Every topic with its type and offered QoS, as the recorder registers them."""
        return [
            (
                topic,
                pub.msg_type,
                QoSProfile(depth=EVENTS_QOS_DEPTH if pub is self.events else QOS_DEPTH),
            )
            for pub, topic in self.topics.items()
        ]

    def asked_by_topic(self) -> list[tuple]:
        """What a subscriber of each publisher asks of the model (drs_model.fidelity.auto)."""
        out = [
            (self.joints, "gap"),
            (self.gap, "gap"),
            (self.markers, "gap"),
            (self.force, "force"),
            (self.accel, "force"),
            (self.reactions, "force"),
        ]
        return out + [(pub, "hydraulics") for pub in self.hydraulic]

    # ---- each published state ------------------------------------------------------------------
    def state_messages(
        self, sim, st, stamp: int, published_stroke, tick: int, recording: bool
    ) -> list[tuple]:
        """``(publisher, bytes)`` of state ``st`` of actuator ``sim``, stamped ``stamp`` [ns]:
        ``published_stroke``: the stroke the sensor reports (None: the true one); ``tick``: the
        tick's number (the listeners are asked every :data:`LISTENER_CHECK_TICKS`);
        ``recording``: a bag records the markers, listened to or not."""
        pack = self._pack_float64
        out = [
            # as the (possibly faulty) stroke sensor reports them: a sensor fault changes the
            # piston's position only, never the simulation
            (self.joints, self._pack_joint_state(st, stamp, published_stroke)),
            (self.force, pack(st.piston_force)),
            (self.gap, pack(st.gap)),
            (self.accel, pack(st.qdd[0])),
        ]
        if self.hydraulic and sim.has_fluid:
            out += self._hydraulic_messages(st, stamp)
        if tick % LISTENER_CHECK_TICKS == 1:  # asking DDS: not every tick
            self.listened = {pub: pub.get_subscription_count() > 0 for pub in self.state_publishers}
        if self.listened[self.reactions]:
            out.append((self.reactions, self._pack_reactions(sim.reactions(), stamp)))
        if (recording or self.listened[self.markers]) and (
            self.last_markers_t is None or st.t - self.last_markers_t >= self.markers_period - 1e-9
        ):
            self.last_markers_t = st.t
            out.append((self.markers, self._markers(st, stamp)))
        return out

    def _hydraulic_messages(self, st, stamp: int) -> list[tuple]:
        """The hydraulic rung's pressures (sensor_msgs/FluidPressure [Pa], stamped like the joint
        states, in ``frame_id``) and its spool (std_msgs/Float64, -1..1; NaN without spool lag,
        where the spool is the servo's command itself)."""
        sec, nanosec = split_ns(stamp)
        pa, pb, ps, spool = self.hydraulic
        pack = self._pack_pressure
        return [
            (pa, pack(sec, nanosec, st.pressure_a)),
            (pb, pack(sec, nanosec, st.pressure_b)),
            (ps, pack(sec, nanosec, st.supply_pressure)),
            (spool, self._pack_float64(math.nan if st.spool is None else st.spool)),
        ]

    def _markers(self, st, stamp: int) -> bytes:
        """The CDR of the mechanism at state ``st`` as RViz and Foxglove draw it
        (drs_ros.drawing), packed (:meth:`~drs_ros.conversions.MechanismMarkers.packer`). A
        flap that has not moved since the last drawing (held open or closed) is not drawn
        again: the drawing of a configuration costs ~40 us of CPU warm and ~90 us on a tick
        after 4 ms idle, and depends on the configuration alone."""
        key = st.q.tobytes()
        if self._drawn is None or self._drawn[0] != key:
            lines, pins, force_at = moving_drawings(st.q[None, :], self.params)
            self._drawn = (key, {k: v[0] for k, v in lines.items()}, pins[0], force_at[0])
        _key, lines, pins, force_at = self._drawn
        # the outlines that never move go out once a second (a marker lives until replaced)
        still = self._last_still_t is None or st.t - self._last_still_t >= STILL_MARKERS_PERIOD_S
        if still:
            self._last_still_t = st.t
        return self._pack_markers(lines, pins, force_at, st.piston_force, stamp, with_still=still)

    def destroy(self, node) -> None:
        for pub in self.all:
            node.destroy_publisher(pub)


__all__ = ["HYDRAULIC_TOPICS", "LISTENER_CHECK_TICKS", "StatePublishers"]
