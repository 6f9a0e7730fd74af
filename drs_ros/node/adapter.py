"""The ``drs`` ROS 2 node: a thin adapter around :class:`drs_model.actuator.ActuatorSim` (or
another rung of :mod:`drs_model.fidelity`, the ``fidelity`` parameter; the hydraulic rung adds
``~/pressure_piston_side``, ``~/pressure_rod_side``, ``~/supply_pressure`` (FluidPressure) and
``~/valve_spool`` (Float64)).

Topics (``~`` is the node namespace, ``/drs/...`` by default):

* ``~/stroke_cmd`` (in, std_msgs/Float64): move smoothly to this stroke [m];
* ``~/force_cmd`` (in, std_msgs/Float64): apply this piston force [N] from now on;
* ``~/trajectory_cmd`` (in, trajectory_msgs/JointTrajectory): follow the piston joint's points;
* ``~/drs`` (service, std_srvs/SetBool): true opens, false closes (the seed's times); its calls
  are published as introspection events on ``~/drs/_service_event``;
* ``/joint_states`` (sensor_msgs/JointState): piston [m, m/s, N], link and flap [rad, rad/s];
* ``~/piston_force``, ``~/flap_gap``, ``~/piston_acceleration`` (std_msgs/Float64): [N], [m],
  [m/s^2];
* ``~/joint_reactions`` (sensor_msgs/JointState): reactions by name, only while subscribed;
* ``~/command_events`` (diagnostic_msgs/DiagnosticArray): the effect record, one message per
  command (accepted, refused or superseded, at which simulated instant) and per clock origin or
  physics reset: with the recorded commands and parameters, a bag re-runs deterministically;
* ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, ~1 Hz): the last few seconds' troubles and
  the cumulative counters.

The physics runs on a fixed simulated step (``physics_rate_hz``); one timer at ``publish_rate_hz``
catches the simulation up with the node clock (wall or ``/clock`` with ``use_sim_time``) and
publishes. Stamps are ``t0 + simulated time``, so they follow the node clock without its jitter.

Commands are latest-wins: a subscription callback only records the bytes that arrived and keeps
the newest command per topic; the next tick applies it before stepping, so no queued, stale
setpoint is ever executed. Every message is recorded as its exact CDR bytes: commands as they
arrived (raw subscriptions, as rosbag2 does), the node's own messages serialised once by
:mod:`drs_ros.recording.cdr`, published as those bytes and recorded as the same bytes.
"""

from __future__ import annotations

import functools
import math
import threading
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import ParameterEvent
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.service_introspection import ServiceIntrospectionState
from sensor_msgs.msg import FluidPressure, JointState
from std_msgs.msg import Float64, Header
from std_srvs.srv import SetBool
from visualization_msgs.msg import MarkerArray

from drs_model.errors import DRSError
from drs_model.fidelity import HydraulicRung, make_rung
from drs_model.fidelity.auto import choose_rung, ladder_errors
from drs_model.fidelity.faults import RunFaults

from .. import commands
from ..conversions import (
    MechanismMarkers,
    joint_state_msg,
    parameter_event_msg,
    reactions_msg,
    time_msg,
)
from ..drawing import moving_drawings, still_drawings
from ..names import ACCEPTED, FIDELITY, REFUSED, RESET, SUPERSEDED, TOPICS
from ..recording import cdr, msgdefs
from ..stack.layer import NodeHooks, StackLayer
from ..timestamps import ns_from_seconds, seconds_from_ns
from .effect_record import EffectRecord, PendingCommand, refusal_reason
from .fault_parameters import NodeFaults, declare_fault_parameters
from .parameters import StartupError, declare_parameters, effective_parameters, model_params
from .recordings import NodeRecordings
from .trajectory_cdr import read_joint_trajectory

QOS_DEPTH = 10
#: The still outlines (FIA box, main wing, pylon) are in ~/markers once per this [s] of sim time.
STILL_MARKERS_PERIOD_S = 1.0
#: Ticks between two questions to DDS whether the optional topics have listeners.
LISTENER_CHECK_TICKS = 25
#: The command topics (``~/<key>``) and their message classes, as commands.COMMAND_TYPES names them.
COMMANDS = {key: msgdefs.message_class(name) for key, name in commands.COMMAND_TYPES.items()}
#: Without /clock for this long under use_sim_time, the node says so (wall time) [s].
CLOCK_WAIT_WARNING_S = 2.0
#: A wall clock that moves this much [s] more or less than the steady clock between two ticks
#: has jumped (NTP slews far slower: 0.5 ms/s at most).
CLOCK_JUMP_THRESHOLD_S = 0.01


class DRSNode(EffectRecord, NodeFaults, NodeRecordings, Node):
    """The DRS actuator node. Keyword arguments go to :class:`rclpy.node.Node`.

    Its life has the stages of a ROS 2 managed node, which
    :class:`~drs_ros.node.managed.ManagedDRSNode` exposes over the standard lifecycle services;
    unmanaged (the default) it configures and activates itself in the constructor:

    * :meth:`configure`: validate the parameters, build the actuator, create the publishers and
      open the recorders (a bad value or path raises, with the reason, leaving nothing behind);
    * :meth:`activate`: create the command subscriptions, the service and the timers;
    * :meth:`deactivate`: remove them again: the actuator holds its state, nothing is published;
    * :meth:`cleanup`: finish the recordings and drop the publishers and the actuator.

    Two parts live in their own modules: the effect record and the diagnostics
    (:class:`~drs_ros.node.effect_record.EffectRecord`) and the recordings
    (:class:`~drs_ros.node.recordings.NodeRecordings`).
    """

    def __init__(self, *, tick_timer: bool = True, managed: bool = False, **kwargs) -> None:
        """``tick_timer=False``: the caller calls :meth:`tick` (see
        :func:`drs_ros.node.runner.run_deadline_loop`);
        ``managed=True``: stay unconfigured until :meth:`configure` is called."""
        super().__init__("drs", **kwargs)
        # callbacks may run in an executor thread while the main thread ticks
        self._lock = threading.Lock()
        declare_fault_parameters(self)  # writable: the only parameters that change at run time
        self._given_parameters = declare_parameters(self)
        self._wall_clock = not self.get_parameter("use_sim_time").value
        self._tick_timer = tick_timer
        self.configured = self.active = False
        self.callback_errors = 0
        self.recorder = self.rerun = None
        self.bag = self.rrd = None  # the recordings and their failures (NodeRecordings)
        self.recording_problems: list[str] = []
        #: The stop the node obeys within a tick (drs_ros.stop_request.StopRequest, set by
        #: drs_ros.node.runner): a long tick ends at the next physics step once it is requested.
        self.stop_request = None
        self.timer = self.diag_timer = self.clock_watch = None
        self.sub_stroke = self.sub_force = self.sub_trajectory = self.srv_drs = None
        self.sub_drs_events = None
        if not managed:
            self.configure()
            self.activate()

    # ---- life stages ---------------------------------------------------------------------------
    def configure(self) -> None:
        """Validate the parameters, build the actuator and the publishers, open the recorders."""
        self.params = model_params(self, self._given_parameters)
        gp = self.get_parameter
        physics_hz, publish_hz = gp("physics_rate_hz").value, gp("publish_rate_hz").value
        if publish_hz > physics_hz:
            raise StartupError(
                f"publish_rate_hz {publish_hz:g} exceeds physics_rate_hz {physics_hz:g}: the node "
                "cannot publish new states faster than it computes them; lower publish_rate_hz "
                "or raise physics_rate_hz"
            )
        self.physics_dt = 1.0 / physics_hz
        self.publish_period = 1.0 / publish_hz
        self.markers_rate_hz = gp("markers_rate_hz").value
        self.markers_period = 1.0 / self.markers_rate_hz
        self.frame_id = gp("frame_id").value
        self.joint_names = list(gp("joint_names").value)
        if len(self.joint_names) != 3:
            raise ParameterException(
                f"joint_names must hold 3 names (piston, link, flap), got {self.joint_names}",
                ["joint_names"],
            )
        self.fidelity = gp("fidelity").value
        # auto: rigid until the subscribers are seen (activate, _choose_fidelity); each rung's
        # errors measured now, for these parameters (a few seconds, once per parameters)
        self._auto_deadline = None
        self._auto_errors = ladder_errors(self.params) if self.fidelity == "auto" else None
        self._make_rung = lambda rung: make_rung(
            rung,
            self.params,
            self.physics_dt,
            force_limit=gp("force_limit").value,
            integrator=gp("integrator").value,
            force_method=gp("force_method").value,
        )
        self.sim = self._make_rung("rigid" if self.fidelity == "auto" else self.fidelity)
        if isinstance(self.sim, HydraulicRung):  # a model too stiff for the physics rate: now
            self.sim.check_stiffness()  # TooStiffError, not a refusal at every tick
        self._start_faults()
        self.max_catch_up = int(gp("max_catch_up_steps").value)
        # a tick late by one period must still catch up, or every tick would drop steps
        needed = math.ceil(2.0 * physics_hz / publish_hz)
        if self.max_catch_up < needed:
            raise StartupError(
                f"max_catch_up_steps {self.max_catch_up} is below the {needed} physics steps of "
                f"two publish periods ({physics_hz:g} Hz physics, {publish_hz:g} Hz publish): "
                f"every late tick would drop simulated time; give max_catch_up_steps >= {needed} "
                "or publish faster"
            )
        lines, pins, _ = moving_drawings(np.array([[self.sim.s_min, 0.0, 0.0]]), self.params)
        self._scene = MechanismMarkers(still_drawings(self.params),
                                       {k: v.shape[1] for k, v in lines.items()}, pins.shape[1],
                                       gp("frame_id").value)  # fmt: skip

        qos = QoSProfile(depth=QOS_DEPTH)
        self.pub_joints = self.create_publisher(JointState, gp("joint_states_topic").value, qos)
        self.pub_force = self.create_publisher(Float64, "~/piston_force", qos)
        self.pub_gap = self.create_publisher(Float64, "~/flap_gap", qos)
        # JointState has no acceleration field; with it a bag replays the piston force exactly
        self.pub_accel = self.create_publisher(Float64, "~/piston_acceleration", qos)
        self.pub_reactions = self.create_publisher(JointState, "~/joint_reactions", qos)
        self.pub_markers = self.create_publisher(MarkerArray, "~/markers", qos)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", qos)
        self.pub_events = self.create_publisher(
            DiagnosticArray, "~/command_events", QoSProfile(depth=100)
        )
        # the hydraulic rung's chamber pressures, supply pressure and valve spool
        self.pub_hydraulic = ()
        if isinstance(self.sim, HydraulicRung) or self.fidelity == "auto":
            self.pub_hydraulic = tuple(
                self.create_publisher(msg_type, f"~/{name}", qos)
                for name, msg_type in HYDRAULIC_TOPICS
            )
        self._own_publishers = (
            self.pub_joints,
            self.pub_force,
            self.pub_gap,
            self.pub_accel,
            self.pub_reactions,
            self.pub_markers,
            self.pub_diag,
            self.pub_events,
            *self.pub_hydraulic,
        )
        self.service_name = self.resolve_service_name("~/drs")
        # resolved names (e.g. /drs/piston_force), fixed for the node's life: the recording keys
        self.topics = {pub: pub.topic_name for pub in self._own_publishers}
        self.command_topics = {key: self.resolve_topic_name(f"~/{key}") for key in COMMANDS}
        # in a vehicle stack (drs_ros.stack): description, TF, the action, JointState commands
        self.stack = StackLayer(self, NodeHooks(
            event=lambda source, outcome, level, reason, values, now: self._event(
                source, outcome, level, reason, None, values, now),
            record=self._record, receive=self._receive, now_ns=self._now_ns))  # fmt: skip
        self.command_topics.update(self.stack.command_topics)
        self._serialize = {
            cls: cdr.serializer(cls)
            for cls in (JointState, DiagnosticArray, MarkerArray, FluidPressure)
        }
        self._pack_float64 = cdr.flat_packer(Float64)
        # a command is taken if it decodes and is as long as its exact CDR (plus transport
        # padding), and recorded as that exact CDR, which every reader of the bag decodes; a
        # trajectory is read in place (rclpy's decoder would hold the GIL for ~100 ms on 10,000
        # points, a stall of the real-time tick)
        self._decode = {key: functools.partial(cdr.decode_exact, msg_class=cls)
                        for key, cls in COMMANDS.items()}  # fmt: skip
        self._decode["trajectory_cmd"] = lambda data: (v := read_joint_trajectory(data), v.exact)
        self._joint_state = JointState(name=self.joint_names)  # filled in place at each publish
        self._listened = {self.pub_reactions: False, self.pub_markers: False}

        self._start_counters(gp("diagnostics_window").value)
        self._pending: dict[str, PendingCommand] = {}
        self._last_tick_ns: int | None = None
        self._last_tick_mono: int | None = None
        self._last_markers_t: float | None = None
        self._last_still_t: float | None = None
        self._t0_ns: int | None = None
        self._started_wall = time.monotonic()
        self._clock_warned = False

        # all paths are checked before any file is created; a failure removes what was made
        self._open_recordings()
        try:
            self._register_recorded_topics()
        except Exception:
            self.discard_recordings()
            raise
        # the first record: the node's name and its topics as resolved (remapping included), so
        # that the bag's tools find them whatever the node was called
        self._event(TOPICS, TOPICS, DiagnosticStatus.OK, "", None,
                    {"node": self.get_fully_qualified_name(), **self.topic_names()},
                    self._now_ns())  # fmt: skip
        self.stack.start(self._now_ns())  # the robot description and the static TF, once
        self.configured = True
        self.get_logger().info(
            f"drs node configured: physics {physics_hz:g} Hz, publish {publish_hz:g} Hz, stroke "
            f"[{self.sim.s_min:.6g}, {self.sim.s_max:.6g}] m"
        )

    def activate(self) -> None:
        """Take commands and publish: the command subscriptions, the service, the timers."""
        cmd_qos = QoSProfile(depth=commands.COMMAND_QOS_DEPTH)
        # raw: the callback gets the bytes that arrived, recorded as they are; only the command
        # that takes effect is ever deserialised
        self.sub_stroke, self.sub_force, self.sub_trajectory = (
            self.create_subscription(
                COMMANDS[key], f"~/{key}", lambda b, key=key: self._receive(key, b), cmd_qos,
                raw=True,
            )
            for key in ("stroke_cmd", "force_cmd", "trajectory_cmd")
        )  # fmt: skip
        self.srv_drs = self.create_service(SetBool, "~/drs", self._on_drs)
        self.srv_drs.configure_introspection(
            self.get_clock(), QoSProfile(depth=100), ServiceIntrospectionState.CONTENTS
        )
        if self.recorder is not None:  # record the service calls as rosbag2 does: their events
            self.sub_drs_events = self.create_subscription(
                SetBool.Event, self.service_event_topic, self._on_service_event,
                QoSProfile(depth=100), raw=True,
            )  # fmt: skip
        use_sim_time = self.get_parameter("use_sim_time").value
        if self._tick_timer or use_sim_time:
            self.timer = self.create_timer(self.publish_period, self.tick)
        self.diag_timer = self.create_timer(1.0, self._on_diagnostics)
        if use_sim_time:  # a steady-clock timer: it runs without /clock
            self.clock_watch = self.create_timer(
                0.5, self._watch_clock, clock=Clock(clock_type=ClockType.STEADY_TIME)
            )
        self._last_tick_ns = None  # the time inactive is no missed deadline
        if self.fidelity == "auto" and self.sim.t == 0.0 and self.ticks == 0:
            wait = self.get_parameter("fidelity_auto_discovery_s").value
            self._auto_deadline = time.monotonic() + wait
        self.stack.activate()  # JointState commands, goals taken
        self.active = True

    def deactivate(self) -> None:
        """Stop taking commands and publishing; the actuator holds its state (no time passes)."""
        self.active = False
        self.stack.deactivate()  # goals aborted, no JointState commands
        for timer in (self.timer, self.diag_timer, self.clock_watch):
            if timer is not None:
                self.destroy_timer(timer)
        for sub in (self.sub_stroke, self.sub_force, self.sub_trajectory, self.sub_drs_events):
            if sub is not None:
                self.destroy_subscription(sub)
        if self.srv_drs is not None:
            self.destroy_service(self.srv_drs)
        self.timer = self.diag_timer = self.clock_watch = None
        self.sub_stroke = self.sub_force = self.sub_trajectory = self.srv_drs = None
        self.sub_drs_events = None
        with self._lock:
            self._pending.clear()  # a command that arrived for the active node acts never
            if self._t0_ns is not None:  # resume from the held state, not from the time away
                self._t0_ns = None

    def cleanup(self) -> None:
        """Finish the recordings and drop the publishers and the actuator."""
        if self.active:
            self.deactivate()
        self.stack.cleanup()
        self.close_recordings()
        self.recorder = self.rerun = None
        for pub in self._own_publishers:
            self.destroy_publisher(pub)
        self.configured = False

    @property
    def service_event_topic(self) -> str:
        return f"{self.service_name}/_service_event"

    def topic_names(self) -> dict[str, str]:
        """Role (of :data:`drs_ros.names.NODE_TOPICS`) -> the name the node resolved it to,
        remapping included: the ``topics`` record of the effect record."""
        publishers = {"joint_states": self.pub_joints, "piston_force": self.pub_force,
                      "flap_gap": self.pub_gap, "piston_acceleration": self.pub_accel,
                      "joint_reactions": self.pub_reactions, "markers": self.pub_markers,
                      "diagnostics": self.pub_diag, "command_events": self.pub_events}  # fmt: skip
        names = {role: pub.topic_name for role, pub in publishers.items()}
        if self.pub_hydraulic:  # the hydraulic rung's (or auto's) topics
            names.update((role, pub.topic_name) for (role, _type), pub
                         in zip(HYDRAULIC_TOPICS, self.pub_hydraulic, strict=True))  # fmt: skip
        names.update(self.command_topics)
        names.update(self.stack.topic_names())
        names.update(drs_service=self.service_name, drs_service_event=self.service_event_topic,
                     parameter_events="/parameter_events")  # fmt: skip
        return names

    # ---- recordings ----------------------------------------------------------------------------
    def _register_recorded_topics(self) -> None:
        if self.recorder is None:
            return
        register = self.recorder.register_topic
        for pub, topic in self.topics.items():
            register(topic, pub.msg_type, qos=QoSProfile(depth=100 if pub is self.pub_events
                                                         else QOS_DEPTH))  # fmt: skip
        for key, topic in self.command_topics.items():
            register(topic, COMMANDS[key], qos=QoSProfile(depth=commands.COMMAND_QOS_DEPTH))
        register(self.service_event_topic, SetBool.Event, qos=QoSProfile(depth=100))
        for topic, msg_type, qos in self.stack.recorded_topics():
            register(topic, msg_type, qos=qos)
        register("/parameter_events", ParameterEvent, qos=QoSProfile(depth=1000))
        now = self._now_ns()
        event = parameter_event_msg(
            self.get_fully_qualified_name(), effective_parameters(self, self.params), now
        )
        self.recorder.write("/parameter_events", event, now)

    # ---- commands ------------------------------------------------------------------------------
    def _now_ns(self) -> int:
        if self._wall_clock:  # the ROS clock without /clock is the system clock; 30x cheaper
            return time.time_ns()
        return self.get_clock().now().nanoseconds

    def _receive(self, key: str, data: bytes) -> None:
        """A raw command arrived (executor thread): decode it and do the state-free part of its
        work here, outside the lock the real-time tick takes (a 10,000-point trajectory is
        planned in ~4 ms), then record it and keep it as the newest of its topic. Its log time
        is taken under the lock: no tick logged after it applies an older command of its topic."""
        topic = self.command_topics[key]
        try:
            msg, exact = self._decode[key](data)
        except Exception as exc:  # noqa: BLE001 - any bytes from any participant: refused, kept
            with self._lock:
                self.received += 1
                self._refuse_malformed(topic, COMMANDS[key], data, exc, self._now_ns())
            return
        try:
            prepared, refusal = commands.prepare(self.sim, key, msg, self.joint_names[0]), None
        except Exception as exc:  # noqa: BLE001 - what a command carries never stops the node
            prepared, refusal = None, exc
        with self._lock:
            now = self._now_ns()
            self.received += 1
            # only bytes that decode go on the typed topic: the bag stays readable by all readers
            # recorded as its exact CDR: the bytes that arrived, any alignment padding zeroed
            cmd = PendingCommand(key, topic, msg, self._record(topic, exact, now), now, prepared)
            if refusal is not None:
                self._refuse_command(cmd, refusal, now)
                return
            older = self._pending.get(key)
            if older is not None:  # counted and recorded (one record per step) when it comes
                cmd.superseded = older.superseded
                cmd.superseded.append(older.sequence)
            self._pending[key] = cmd

    def _apply_pending(self, now_ns: int) -> None:
        """Apply the newest command of each topic at the present physics step, oldest first."""
        pending = sorted(self._pending.values(), key=lambda c: c.received_ns)
        self._pending.clear()
        for cmd in pending:
            if cmd.superseded:
                n = len(cmd.superseded)
                self.superseded += n
                reason = f"{n} {cmd.key} replaced by a newer one before the next physics step"
                self.troubles.add(now_ns, SUPERSEDED, reason)
                known = [q for q in cmd.superseded if q is not None]
                self._event(cmd.topic, SUPERSEDED, DiagnosticStatus.STALE, reason, None, {
                    "count": n, "sequences": f"{known[0]}..{known[-1]}" if known else "",
                }, now_ns)  # fmt: skip
            try:
                commands.apply(self.sim, cmd.key, cmd.msg, self.joint_names[0], cmd.prepared)
            except Exception as exc:  # noqa: BLE001 - what a command carries never stops the node
                self._refuse_command(cmd, exc, now_ns)
                continue
            self.accepted += 1
            value = commands.describe(cmd.key, cmd.msg)
            self._event(
                cmd.topic, ACCEPTED, DiagnosticStatus.OK, "", cmd, {"value": repr(value)}, now_ns
            )

    def _on_drs(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        with self._lock:
            return self._on_drs_locked(request, response)

    def _on_drs_locked(self, request, response):
        # a service call takes effect at once: the simulation is between two physics steps
        now = self._now_ns()
        if self._auto_deadline is not None:  # a call before auto chose: choose now
            self._choose_fidelity(now)
        self._apply_pending(now)  # commands that arrived earlier act first, as they would have
        value = commands.describe(commands.SERVICE_KEY, request)
        try:
            seg = commands.apply(self.sim, commands.SERVICE_KEY, request, self.joint_names[0])
        except Exception as exc:  # noqa: BLE001 - what a request carries never stops the node
            response.success = False
            response.message = self._refuse("drs", value, refusal_reason(exc), now)
            self._event(
                self.service_name,
                REFUSED,
                DiagnosticStatus.WARN,
                response.message,
                None,
                {"value": repr(value)},
                now,
            )
            return response
        self.accepted += 1
        response.success = True
        response.message = (
            f"{'opening' if value else 'closing'} to {seg.evaluate(seg.t1)[0]:.6g} m "
            f"in {seg.duration:g} s"
        )
        self._event(
            self.service_name, ACCEPTED, DiagnosticStatus.OK, "", None, {"value": repr(value)}, now
        )
        return response

    def _on_service_event(self, data: bytes) -> None:
        # an event ends in a string, so the transport may have padded it (cdr.exact_bytes)
        try:
            data = cdr.exact_bytes(data, SetBool.Event)
        except cdr.CdrError as exc:
            self.get_logger().error(f"service event not recorded: {exc}")
            return
        self._record(self.service_event_topic, data, self._now_ns())

    # ---- the loop ------------------------------------------------------------------------------
    def _watch_clock(self) -> None:
        if self._now_ns() != 0:
            self.clock_watch.cancel()
            return
        if not self._clock_warned and time.monotonic() - self._started_wall > CLOCK_WAIT_WARNING_S:
            self._clock_warned = True
            self.get_logger().warning(
                f"use_sim_time is set and no /clock message arrived in {CLOCK_WAIT_WARNING_S:g} s: "
                "the simulation waits for /clock and publishes nothing"
            )

    def tick(self) -> None:
        """Catch the simulation up with the node clock, apply the newest commands, publish."""
        with self._lock:
            self._tick_locked()

    def _tick_locked(self) -> None:
        # one node time per tick: every stamp and log time of the tick derives from it, so a
        # record of the tick (a new clock origin) is never logged after the states it governs
        now = self._now_ns()
        if now == 0:  # use_sim_time before the first /clock message
            return
        if self._auto_deadline is not None:
            if time.monotonic() < self._auto_deadline:
                return  # auto: the subscribers are still being discovered
            self._choose_fidelity(now)
        mono = time.monotonic_ns()
        if self._t0_ns is None:
            self._t0_ns = now - ns_from_seconds(self.sim.t)
            self._record_clock_origin(now)
        elif self._last_tick_ns is not None:
            self._check_clock_jump(now, mono)
        if (
            self._last_tick_ns is not None
            and now - self._last_tick_ns > ns_from_seconds(1.5 * self.publish_period)
        ):
            self.missed_deadlines += 1
            self.troubles.add(
                now,
                "missed_deadline",
                f"tick {seconds_from_ns(now - self._last_tick_ns) * 1e3:.1f} ms after the last",
            )
        self._last_tick_ns, self._last_tick_mono = now, mono
        self.ticks += 1
        t = time.process_time()
        if self._pending:
            self._apply_pending(now)
        if self._pending_faults:
            self._apply_faults(now)
        target = seconds_from_ns(now - self._t0_ns)
        due = int(math.floor((target - self.sim.t) / self.physics_dt + 1e-9))
        if due > self.max_catch_up:
            # too far behind (a stall): drop the excess instead of spiralling
            dropped = due - self.max_catch_up
            self.dropped_steps += dropped
            self.troubles.add(now, "dropped_steps", f"{dropped} physics steps dropped")
            self._t0_ns += ns_from_seconds(dropped * self.physics_dt)
            self._record_clock_origin(now, DiagnosticStatus.WARN, f"{dropped} steps dropped")
            due = self.max_catch_up
        try:
            self._advance(due)
        except DRSError as exc:  # the model refuses to go on: at rest where it is, and say why
            reason = self._refuse("step", self.sim.mode, str(exc), now)
            s_rest = commands.reset_at_rest(self.sim)
            self._event(
                RESET, RESET, DiagnosticStatus.WARN, reason, None, {"stroke": repr(s_rest)}, now
            )
        self._cpu["model"] += time.process_time() - t
        if due > 0 or self.ticks == 1:  # publish new states only (stamps strictly increase)
            self._publish(now)

    def _advance(self, due: int) -> None:
        """``due`` physics steps, one at a time, each bounded (the hydraulic rung caps its
        sub-steps): a stop requested meanwhile ends the tick at the next step, so that a tick
        that overruns (a stall, a catch-up of many steps) stays stoppable within one step."""
        stop = self.stop_request
        for k in range(due):
            if stop is not None and stop.requested:
                self.get_logger().info(
                    f"stop requested: the last tick ends after {k} of its {due} physics steps, "
                    f"at simulated time {self.sim.t:.6f} s"
                )
                return
            self.sim.advance(1)

    def _choose_fidelity(self, now_ns: int) -> None:
        """``fidelity: auto``: the lowest rung that meets ``fidelity_tolerance`` and
        ``fidelity_force_tolerance`` for what the node's subscribers ask, by the errors measured
        at configure for the node's parameters (:func:`drs_model.fidelity.auto.choose_rung`),
        chosen once, before the first step, and recorded (source ``fidelity``) so that a re-run
        takes the same rung."""
        self._auto_deadline = None
        asked = {kind for pub, kind in self._asked_by_topic() if pub.get_subscription_count()}
        gp = self.get_parameter
        rung = choose_rung(asked, gp("fidelity_tolerance").value,
                           gp("fidelity_force_tolerance").value, self._auto_errors)  # fmt: skip
        if rung != self.sim.name:
            self.sim = self._make_rung(rung)
            self.faults = RunFaults(self.sim)  # none applied yet: they act at ticks
            if getattr(self.stack, "action", None) is not None:
                self.stack.action.sim = self.sim
        self.get_logger().info(f"fidelity auto: {rung} for {sorted(asked) or 'nothing'} asked")
        self._event(FIDELITY, FIDELITY, DiagnosticStatus.OK, "", None,
                    {"rung": rung, "asked": ",".join(sorted(asked))}, now_ns)  # fmt: skip

    def _asked_by_topic(self) -> list[tuple]:
        """What a subscriber of each publisher asks of the model (drs_model.fidelity.auto)."""
        out = [(self.pub_joints, "gap"), (self.pub_gap, "gap"), (self.pub_markers, "gap"),
               (self.pub_force, "force"), (self.pub_accel, "force"),
               (self.pub_reactions, "force")]  # fmt: skip
        return out + [(pub, "hydraulics") for pub in self.pub_hydraulic]

    def _check_clock_jump(self, now: int, mono: int) -> None:
        """A node clock that jumps (the system clock stepped by NTP or by hand; ``/clock`` going
        back, as ``drs-bag play --loop --clock`` does) moves the clock origin by the jump, as
        ROS 2's time-jump callbacks would: the simulation goes on from its state, in step with
        the new clock, and the jump is recorded. Without it, a clock stepped back froze the
        simulation until the clock caught up again."""
        if self._wall_clock:  # the wall clock against the steady one: any difference is a jump
            jump = (now - self._last_tick_ns) - (mono - self._last_tick_mono)
            if abs(jump) < ns_from_seconds(CLOCK_JUMP_THRESHOLD_S):
                return
        else:  # /clock may run at any rate: only a step back is a jump
            if now >= self._last_tick_ns:
                return
            jump = now - self._last_tick_ns
        self._t0_ns += jump
        self.clock_jumps += 1
        way = "forward" if jump > 0 else "back"
        reason = f"node clock jumped {way} by {seconds_from_ns(abs(jump)):.6g} s"
        self.troubles.add(now, "clock_jump", reason)
        self.get_logger().warning(f"{reason}: the simulation goes on from its state")
        self._record_clock_origin(now, DiagnosticStatus.WARN, reason, jump_ns=jump)
        self._last_tick_ns = now  # no missed deadline for the jump itself

    def _publish(self, now_ns: int) -> None:
        t = time.process_time()
        st = self.sim.state
        stamp = self._t0_ns + ns_from_seconds(st.t)
        pack = self._pack_float64
        out = [
            (self.pub_joints, self._serialize[JointState](
                self._published_joint_state(st, stamp))),
            (self.pub_force, pack(st.piston_force)),
            (self.pub_gap, pack(st.gap)),
            (self.pub_accel, pack(st.qdd[0])),
        ]  # fmt: skip
        if self.pub_hydraulic and isinstance(self.sim, HydraulicRung):
            out += self._hydraulic_messages(st, stamp)
        if self.ticks % LISTENER_CHECK_TICKS == 1:  # asking DDS costs ~25 us: not every tick
            self._listened = {pub: pub.get_subscription_count() > 0
                              for pub in (self.pub_reactions, self.pub_markers)}  # fmt: skip
        if self._listened[self.pub_reactions]:
            reactions = reactions_msg(self.sim.reactions(), stamp)
            out.append((self.pub_reactions, self._serialize[JointState](reactions)))
        if (self.recorder is not None or self._listened[self.pub_markers]) and (
            self._last_markers_t is None
            or st.t - self._last_markers_t >= self.markers_period - 1e-9
        ):
            self._last_markers_t = st.t
            out.append((self.pub_markers, self._serialize[MarkerArray](self._markers(st, stamp))))
        for pub, data in out:
            pub.publish(data)
        t1 = time.process_time()
        self._cpu["publish"] += t1 - t
        for pub, data in out:
            self._record(self.topics[pub], data, now_ns)
        self.stack.publish(st, stamp, now_ns)  # /tf, the action's feedback
        self._log_rerun(st)  # its own failures: never the bag's
        self._cpu["record"] += time.process_time() - t1

    def _published_joint_state(self, st, stamp: int) -> JointState:
        """The joint states as the (possibly faulty) stroke sensor reports them: a sensor fault
        changes the piston's position only, never the simulation."""
        msg = joint_state_msg(st, self.joint_names, stamp, self._joint_state)
        if not self.faults.sensor_healthy:
            msg.position[0] = self.faults.published_stroke(st.t, float(st.q[0]))
        return msg

    def _hydraulic_messages(self, st, stamp: int) -> list[tuple]:
        """The hydraulic rung's pressures (sensor_msgs/FluidPressure [Pa], stamped like the joint
        states, in ``frame_id``) and its spool (std_msgs/Float64, -1..1; NaN without spool lag,
        where the spool is the servo's command itself)."""
        header = Header(stamp=time_msg(stamp), frame_id=self.frame_id)
        pa, pb, ps, spool = self.pub_hydraulic
        ser = self._serialize[FluidPressure]
        return [
            (pa, ser(FluidPressure(header=header, fluid_pressure=st.pressure_a))),
            (pb, ser(FluidPressure(header=header, fluid_pressure=st.pressure_b))),
            (ps, ser(FluidPressure(header=header, fluid_pressure=st.supply_pressure))),
            (spool, self._pack_float64(math.nan if st.spool is None else st.spool)),
        ]

    def _markers(self, st, stamp: int) -> MarkerArray:
        """The mechanism at state ``st`` as RViz and Foxglove draw it (drs_ros.drawing)."""
        lines, pins, force_at = moving_drawings(st.q[None, :], self.params)
        # the outlines that never move go out once a second (a marker lives until replaced)
        still = self._last_still_t is None or st.t - self._last_still_t >= STILL_MARKERS_PERIOD_S
        if still:
            self._last_still_t = st.t
        return self._scene.msg(
            {k: v[0] for k, v in lines.items()},
            pins[0],
            force_at[0],
            st.piston_force,
            stamp,
            with_still=still,
        )


#: The hydraulic rung's topics (under the node's name): chamber pressures, supply, spool.
HYDRAULIC_TOPICS = (
    ("pressure_piston_side", FluidPressure),
    ("pressure_rod_side", FluidPressure),
    ("supply_pressure", FluidPressure),
    ("valve_spool", Float64),
)

__all__ = ["COMMANDS", "DRSNode", "HYDRAULIC_TOPICS"]
