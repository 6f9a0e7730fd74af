"""The ``drs`` ROS 2 node: a thin adapter around :class:`drs_model.actuator.ActuatorSim` (or
another rung of :mod:`drs_model.fidelity`, the ``fidelity`` parameter; the hydraulic rung adds
``~/pressure_piston_side``, ``~/pressure_rod_side``, ``~/supply_pressure`` (FluidPressure) and
``~/valve_spool`` (Float64)).

Topics (``~`` is the node namespace, ``/drs/...`` by default):

* ``~/stroke_cmd`` (in, std_msgs/Float64): move smoothly to this stroke [m];
* ``~/force_cmd`` (in, std_msgs/Float64): apply this piston force [N] from now on;
* ``~/trajectory_cmd`` (in, trajectory_msgs/JointTrajectory): follow the piston joint's points;
* ``~/drs`` (service, std_srvs/SetBool): true opens, false closes (the seed's times, longer
  where they need more than ``force_limit``); its calls are published as introspection events
  on ``~/drs/_service_event``;
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

The node owns its parts, each in its module: the command intake (:mod:`.intake`, latest-wins),
the publishers, the effect record, the vehicle-stack layer (:mod:`drs_ros.stack.layer`), the
faults, the recordings (and :mod:`.recorded_topics`), the wait for ``/clock``
(:mod:`.clock_wait`) and the tick gate (:mod:`.tick_gate`: the ticks and the long callbacks).
"""

from __future__ import annotations

import threading
import time

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.service_introspection import ServiceIntrospectionState
from std_srvs.srv import SetBool

from .. import commands
from ..conversions import diagnostics_status, parameter_event_msg
from ..log_throttle import LogThrottle
from ..names import FIDELITY, TOPICS
from ..recording import cdr
from ..recording.diagnostic_cdr import diagnostic_array_cdr
from ..stack.layer import NodeHooks, StackLayer, StackModel
from ..timestamps import ns_from_seconds
from .clock_wait import ClockWait
from .effect_record import EffectRecord, diagnostics_values, error_text
from .fault_parameters import NodeFaults, declare_fault_parameters
from .intake import COMMANDS, CommandIntake
from .parameters import (
    TickSettings,
    declare_parameters,
    effective_parameters,
    model_params,
    serve_model_parameters,
    tick_settings,
)
from .publishers import HYDRAULIC_TOPICS, StatePublishers
from .recorded_topics import register_recorded_topics
from .recordings import NodeRecordings
from .rung_choice import RungChoice
from .service_event_cdr import exact_set_bool_event
from .tick import SimulationClock, Tick, TickParts
from .tick_gate import TickGate


class DRSNode(Node):
    """The DRS actuator node. Keyword arguments go to :class:`rclpy.node.Node`.

    Its life has the stages of a ROS 2 managed node, which
    :class:`~drs_ros.node.managed.ManagedDRSNode` exposes over the standard lifecycle services;
    unmanaged (the default) it configures and activates itself in the constructor:

    * :meth:`configure`: validate the parameters, build the actuator, create the publishers and
      open the recorders (a bad value or path raises, with the reason, leaving nothing behind);
    * :meth:`activate`: create the command subscriptions, the service and the timers;
    * :meth:`deactivate`: remove them again: goals end, a moving piston is held where it is
      (joint_trajectory_controller's hold, once active again: no time passes inactive),
      nothing is published;
    * :meth:`cleanup`: finish the recordings and drop the publishers and the actuator.

    Its parts: ``recordings`` and ``fault_parameters`` (built with the node), then, built by
    :meth:`configure`, ``rungs`` (the actuator's rung), ``outputs`` (the publishers),
    ``effects`` (the effect record and counters), ``stack`` (the vehicle stack) and ``intake``
    (the commands), ``tick_part`` (:mod:`.tick`: the simulation's clock and the tick) and
    ``clock_wait`` (:mod:`.clock_wait`).
    """

    def __init__(self, *, tick_timer: bool = True, managed: bool = False, **kwargs) -> None:
        """``tick_timer=False``: the caller calls :meth:`tick` (see
        :func:`drs_ros.node.runner.run_deadline_loop`);
        ``managed=True``: stay unconfigured until :meth:`configure` is called."""
        super().__init__("drs", **kwargs)
        self._lock = threading.Lock()  # the executor thread's callbacks and the ticks share it
        self.tick_gate = TickGate()  # the deadline loop's ticks run through it
        declare_fault_parameters(self)  # writable: the only parameters that change at run time
        self._given_parameters = declare_parameters(self)
        self._wall_clock = not self.get_parameter("use_sim_time").value
        self._tick_timer = tick_timer
        self.configured, self.active, self.callback_errors = False, False, 0
        self._log_callback_error = LogThrottle(self.get_logger().error)  # one line a second
        self._log_bad_service_event = LogThrottle(self.get_logger().error)
        # the bag and the rerun recording, and their failures: opened at configure
        self.recordings = NodeRecordings(self.get_logger(), self._recording_lost)
        self.fault_parameters = NodeFaults(self, self._lock, self._now_ns, lambda: self.configured)
        #: The stop the node obeys within a tick (drs_ros.stop_request.StopRequest, set by
        #: drs_ros.node.runner): a long tick ends at the next physics step once it is requested.
        self.stop_request = None
        self.timer = self.diag_timer = self.clock_watch = self.sub_drs_events = None
        self.sub_stroke = self.sub_force = self.sub_trajectory = self.srv_drs = None
        if not managed:
            self.configure()
            self.activate()

    # ---- life stages ---------------------------------------------------------------------------
    def configure(self) -> None:
        """Validate the parameters, build the actuator and the publishers, open the recorders."""
        settings = self._read_parameters()
        self._make_actuator()
        self._make_outputs(settings)
        self._make_command_parts()
        self._make_tick()
        self._open_recordings(settings)
        self._announce(settings)

    def _read_parameters(self) -> TickSettings:
        """The model's parameters (served read-only as ``model.*`` and ``hydraulic.*``) and the
        node's settings (:func:`~.parameters.tick_settings`, returned), validated."""
        self.params, self.hydraulic = model_params(self, self._given_parameters)
        serve_model_parameters(self, self.params, self.hydraulic)
        settings = tick_settings(self)
        self.physics_dt, self.publish_period = settings.physics_dt, settings.publish_period
        self.max_catch_up, self.fidelity = settings.max_catch_up, settings.fidelity
        self.markers_rate_hz, self.frame_id = settings.markers_rate_hz, settings.frame_id
        self.joint_names = list(settings.joint_names)
        return settings

    def _make_actuator(self) -> None:
        """The actuator: the ``fidelity`` parameter's rung (``auto``: ``rigid`` until the
        subscribers are seen, :class:`~.rung_choice.RungChoice`)."""
        gp = self.get_parameter
        self.rungs = RungChoice(
            self.fidelity,
            (self.params, self.hydraulic),
            self.physics_dt,
            {
                name: gp(name).value
                for name in ("force_limit", "integrator", "force_method", "limit_moves")
            },
            gp("fidelity_tolerance").value,
            gp("fidelity_force_tolerance").value,
        )
        self.sim = self.rungs.first()

    def _make_outputs(self, settings: TickSettings) -> None:
        """The publishers, the effect record and the faults' start on the actuator."""
        self.outputs = StatePublishers(
            self,
            joint_states_topic=self.get_parameter("joint_states_topic").value,
            joint_names=self.joint_names,
            frame_id=self.frame_id,
            params=self.params,
            s_min=self.sim.s_min,
            markers_period=settings.markers_period,
            hydraulic=self.sim.has_fluid or self.fidelity == "auto",
        )
        self.effects = EffectRecord(
            self.outputs.events,
            self._record,
            lambda: (self.sim.t, self.sim.steps, self.clock.t0_ns),
            self.get_logger(),
            self.get_parameter("diagnostics_window").value,
        )
        self.fault_parameters.start(
            self.sim, self.effects, self._record, lambda: self.recordings.bag is not None
        )

    def _make_command_parts(self) -> None:
        """The command topics and service as resolved, the vehicle-stack layer and the intake."""
        self.service_name = self.resolve_service_name("~/drs")
        self.command_topics = {key: self.resolve_topic_name(f"~/{key}") for key in COMMANDS}
        # in a vehicle stack (drs_ros.stack): description, TF, the action, JointState commands
        self.stack = StackLayer(
            self,
            StackModel(self.params, tuple(self.joint_names), self.frame_id),
            NodeHooks(
                event=lambda source, outcome, level, reason, values, now: self.effects.event(
                    source, outcome, level, reason, None, values, now
                ),
                record=self._record,
                receive=lambda key, data: self.intake.receive(key, data),
                now_ns=self._now_ns,
                actuator=lambda: self.sim,
            ),
        )
        self.command_topics.update(self.stack.command_topics)
        self.intake = CommandIntake(
            self.command_topics,
            self.service_name,
            self.joint_names[0],
            self.effects,
            lambda: self.sim,
            self._lock,
            self._now_ns,
            lambda: self.clock.stamp_ns(self.sim.t),  # the state the next tick acts on
            self._record,
        )

    def _make_tick(self) -> None:
        """The simulation's clock and the tick that steps the actuator and publishes."""
        self.clock = SimulationClock(self._wall_clock, ns_from_seconds(self.publish_period))
        self.tick_part = Tick(
            TickParts(
                actuator=lambda: self.sim,
                intake=self.intake,
                fault_parameters=self.fault_parameters,
                effects=self.effects,
                now_ns=self._now_ns,
                publish=self._publish,
                choose_fidelity=self._choose_fidelity,
                fidelity_deadline=lambda: self.rungs.deadline,
                stop_request=lambda: self.stop_request,
                log_info=self.get_logger().info,
                log_warning=self.get_logger().warning,
            ),
            self.clock,
            self.physics_dt,
            self.max_catch_up,
        )
        self.clock_wait = ClockWait(self._now_ns, self.get_logger().warning)

    def _open_recordings(self, settings: TickSettings) -> None:
        """The bag and the rerun recording opened, the recorded topics registered."""
        # all paths are checked before any file is created; a failure removes what was made
        # the recordings of every cycle are one part: a managed node configured again records to
        # the next cycle's names, and the stop names what any cycle's recordings lack
        gp = self.get_parameter
        self.recordings.open(
            gp("bag_path").value,
            gp("rrd_path").value,
            gp("rerun_connect").value,
            gp("flush_period").value,
            self.params,
            self.markers_rate_hz,
            settings.publish_hz,
        )
        recorder = self.recordings.recorder
        try:
            if recorder is not None:
                register_recorded_topics(
                    recorder,
                    self.outputs.recorded_topics(),
                    self.command_topics,
                    self.service_event_topic,
                    self.stack.recorded_topics(),
                    self._parameter_event,
                    self._now_ns,
                )
        except Exception:
            self.recordings.discard()
            raise

    def _parameter_event(self, now_ns: int):
        """The node's parameters as a ParameterEvent message stamped ``now_ns`` [ns]."""
        fqn = self.get_fully_qualified_name()
        return parameter_event_msg(fqn, effective_parameters(self), now_ns)

    def _announce(self, settings: TickSettings) -> None:
        """The first record, the stack's description and static TF; configured from now."""
        # the first record: the node's name and its topics as resolved (remapping included), so
        # that the bag's tools find them whatever the node was called
        topics = {"node": self.get_fully_qualified_name(), **self.topic_names()}
        self.effects.event(TOPICS, TOPICS, DiagnosticStatus.OK, "", None, topics, self._now_ns())
        self.stack.start(self._now_ns())  # the robot description and the static TF, once
        self.configured = True
        self.get_logger().info(
            f"drs node configured: physics {settings.physics_hz:g} Hz, publish "
            f"{settings.publish_hz:g} Hz, stroke "
            f"[{self.sim.s_min:.6g}, {self.sim.s_max:.6g}] m"
        )

    def activate(self) -> None:
        """Take commands and publish: the command subscriptions, the service, the timers."""
        cmd_qos = QoSProfile(depth=commands.COMMAND_QOS_DEPTH)
        # raw: the callback gets the bytes that arrived, recorded as they are; only the command
        # that takes effect is ever deserialised
        self.sub_stroke, self.sub_force, self.sub_trajectory = (
            self.create_subscription(
                COMMANDS[key],
                f"~/{key}",
                lambda b, key=key: self.intake.receive(key, b),
                cmd_qos,
                raw=True,
            )
            for key in ("stroke_cmd", "force_cmd", "trajectory_cmd")
        )
        self.srv_drs = self.create_service(SetBool, "~/drs", self._on_drs)
        self.srv_drs.configure_introspection(
            self.get_clock(), QoSProfile(depth=100), ServiceIntrospectionState.CONTENTS
        )
        if self.recordings.recorder is not None:  # record the service calls as rosbag2 does
            self.sub_drs_events = self.create_subscription(
                SetBool.Event,
                self.service_event_topic,
                self._on_service_event,
                QoSProfile(depth=100),
                raw=True,
            )
        use_sim_time = self.get_parameter("use_sim_time").value
        if self._tick_timer or use_sim_time:
            self.timer = self.create_timer(self.publish_period, self.tick)
        self.diag_timer = self.create_timer(1.0, self._on_diagnostics)
        if use_sim_time:  # a steady-clock timer: it runs without /clock
            self.clock_watch = self.clock_wait.start(self)
        self.clock.pause()  # the time inactive is no missed deadline
        if self.fidelity == "auto" and self.sim.t == 0.0 and self.effects.ticks == 0:
            self.rungs.wait_for_subscribers(self.get_parameter("fidelity_auto_discovery_s").value)
        self.stack.activate()  # JointState commands, goals taken
        self.active = True

    def deactivate(self) -> None:
        """Stop taking commands and publishing; a moving piston is held where it is (the
        action's hold, which runs once active again: no time passes while inactive)."""
        self.active = False
        with self._lock:  # the hold is a command: never within a tick
            self.stack.deactivate()  # goals aborted, the piston held, no JointState commands
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
            self.intake.clear()  # a command that arrived for the active node acts never
            self.clock.pause()  # resume from the held state, not from the time away

    def cleanup(self) -> None:
        """Finish the recordings and drop the publishers and the actuator."""
        if self.active:
            self.deactivate()
        self.stack.cleanup()
        self.close_recordings()
        self.outputs.destroy(self)
        self.configured = False

    @property
    def service_event_topic(self) -> str:
        return f"{self.service_name}/_service_event"

    def topic_names(self) -> dict[str, str]:
        """Role (of :data:`drs_ros.names.NODE_TOPICS`) -> the name the node resolved it to,
        remapping included: the ``topics`` record of the effect record."""
        names = self.outputs.topic_names()
        names.update(self.command_topics)
        names.update(self.stack.topic_names())
        names.update(
            drs_service=self.service_name,
            drs_service_event=self.service_event_topic,
            parameter_events="/parameter_events",
        )
        return names

    # ---- diagnostics ---------------------------------------------------------------------------
    def diagnostics_values(self) -> dict[str, object]:
        """The state, the counters, the faults, the recordings and the CPU spent, by name."""
        return diagnostics_values(
            self.sim.state,
            self.effects,
            self.fault_parameters.text(),
            self.callback_errors,
            self.recordings.status(),
        )

    def diagnostics_level(self, now_ns: int) -> tuple[bytes, str]:
        """OK, WARN or ERROR with the reason, from the troubles of the recent window only."""
        return self.effects.level(now_ns, self.recordings.failures(), self.sim.mode)

    def executor_error(self, exc: Exception) -> None:
        """A callback (or the middleware taking a message for it) raised: counted, reported in
        diagnostics, and the node goes on."""
        reason = error_text(exc)
        with self._lock:
            self.callback_errors += 1
            if self.configured:
                self.effects.troubles.add(self._now_ns(), "callback_error", reason)
        self._log_callback_error(f"a callback failed, the node goes on: {reason}")

    def _on_diagnostics(self) -> None:
        self.tick_gate.clear_of_ticks()  # ~0.35 ms of Python: after a tick, not over one
        now = self._now_ns()
        with self._lock:  # the main thread may be stepping the actuator (deadline executor)
            level, message = self.diagnostics_level(now)
            values = self.diagnostics_values()
        # packed straight into CDR: no rclpy message built on the executor thread (its GIL)
        status = diagnostics_status(self.get_name(), level, message, values)
        data = diagnostic_array_cdr(now, [status])
        pubs = self.outputs
        pubs.diagnostics.publish(data)
        self._record(pubs.topics[pubs.diagnostics], data, now)

    # ---- recordings ----------------------------------------------------------------------------
    def _record(self, topic: str, data, now_ns: int) -> int | None:
        """Exact bytes (or a message) into the bag: the sequence number (None: not recorded)."""
        return self.recordings.record(topic, data, now_ns)

    def _recording_lost(self, reason: str) -> None:
        """An item a recording lost: a trouble of the diagnostics window."""
        self.effects.troubles.add(self._now_ns(), "recording_error", reason)

    def close_recordings(self) -> list[str]:
        """Finish the bag and the rerun recording (idempotent): one line per recording that is
        incomplete, naming what it lacks (:meth:`NodeRecordings.close`)."""
        return self.recordings.close()

    # ---- commands ------------------------------------------------------------------------------
    def _now_ns(self) -> int:
        if self._wall_clock:  # the ROS clock without /clock is the system clock; 30x cheaper
            return time.time_ns()
        return self.get_clock().now().nanoseconds

    def _on_drs(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.tick_gate.clear_of_ticks()  # its callbacks (0.3-0.8 ms) after a tick, not over one
        self.intake.before_drs(request)  # outside the lock the tick takes
        with self._lock:
            now = self._now_ns()
            if self.rungs.deadline is not None:  # a call before auto chose: choose now
                self._choose_fidelity(now)
            return self.intake.on_drs(request, response, now)

    def _on_service_event(self, data: bytes) -> None:
        # an event ends in a string, so the transport may have padded it (service_event_cdr)
        try:
            data = exact_set_bool_event(data)
        except cdr.CdrError as exc:
            self._log_bad_service_event(f"service event not recorded: {exc}")
            return
        self._record(self.service_event_topic, data, self._now_ns())

    # ---- the loop ------------------------------------------------------------------------------
    def tick(self) -> None:
        """Catch the simulation up with the node clock, apply the newest commands, publish
        (:class:`~drs_ros.node.tick.Tick`)."""
        with self._lock:
            self.tick_part.run()

    def _choose_fidelity(self, now_ns: int) -> None:
        """``fidelity: auto``: the lowest rung that meets ``fidelity_tolerance`` and
        ``fidelity_force_tolerance`` for what the node's subscribers ask, by the errors measured
        at configure for the node's parameters (:func:`drs_model.fidelity.auto.choose_rung`),
        chosen once, before the first step, and recorded (source ``fidelity``) so that a re-run
        takes the same rung."""
        asked = {
            kind for pub, kind in self.outputs.asked_by_topic() if pub.get_subscription_count()
        }
        rung = self.rungs.choose(asked)
        if rung != self.sim.name:
            self.sim = self.rungs.make(rung)
            self.fault_parameters.new_actuator(self.sim)  # none applied yet: they act at ticks
        self.get_logger().info(f"fidelity auto: {rung} for {sorted(asked) or 'nothing'} asked")
        chosen = {"rung": rung, "asked": ",".join(sorted(asked))}
        self.effects.event(FIDELITY, FIDELITY, DiagnosticStatus.OK, "", None, chosen, now_ns)

    def _publish(self, now_ns: int) -> None:
        t = time.thread_time()  # this thread's own CPU: the executor's is not the tick's
        st = self.sim.state
        stamp = self.clock.stamp_ns(st.t)
        faults = self.fault_parameters.faults
        sensed = None if faults.sensor_healthy else faults.published_stroke(st.t, float(st.q[0]))
        recording = self.recordings.recorder is not None
        out = self.outputs.state_messages(
            self.sim, st, stamp, sensed, self.effects.ticks, recording=recording
        )
        listened = self.outputs.listened
        for pub, data in out:
            if listened[pub]:  # no subscriber: DDS would deliver it to no one
                pub.publish(data)
        t1 = time.thread_time()
        self.effects.cpu["publish"] += t1 - t
        topics = self.outputs.topics
        records = [(topics[pub], data) for pub, data in out]
        records += self.stack.transforms(st, stamp, recording)  # /tf: one bag write for all
        self.recordings.record_many(records, now_ns)
        self.stack.update_action(stamp, now_ns)  # the action's goals and feedback
        self.recordings.log_state(st)  # its own failures: never the bag's
        self.effects.cpu["record"] += time.thread_time() - t1


__all__ = ["COMMANDS", "DRSNode", "HYDRAULIC_TOPICS"]
