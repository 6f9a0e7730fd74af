"""The ``drs`` ROS 2 node: a thin adapter around :class:`drs_model.actuator.ActuatorSim`.

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
:mod:`drs_ros.cdr`, published as those bytes and recorded as the same bytes.
"""

from __future__ import annotations

import collections
import dataclasses
import difflib
import functools
import hashlib
import math
import os
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterEvent
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rclpy.service_introspection import ServiceIntrospectionState
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from drs_model.actuator import ActuatorSim
from drs_model.errors import DRSError
from drs_model.params import NUMERIC_FIELDS, DRSParams, from_dict, from_file

from . import cdr, commands
from .conversions import (
    MechanismMarkers,
    command_event_msg,
    diagnostics_msg,
    joint_state_msg,
    parameter_event_msg,
    reactions_msg,
)
from .drawing import moving_drawings, still_drawings
from .names import ACCEPTED, CLOCK, DEFAULT_JOINT_NAMES, REFUSED, RESET, SUPERSEDED
from .stack import STACK_COMMANDS, STACK_PARAMETERS, NodeHooks, StackLayer
from .trajectory_cdr import read_joint_trajectory

QOS_DEPTH = 10
#: The still outlines (FIA box, main wing, pylon) are in ~/markers once per this [s] of sim time.
STILL_MARKERS_PERIOD_S = 1.0
#: Ticks between two questions to DDS whether the optional topics have listeners.
LISTENER_CHECK_TICKS = 25
#: The command topics (``~/<key>``) and their message types.
COMMANDS = {"stroke_cmd": Float64, "force_cmd": Float64, "trajectory_cmd": JointTrajectory,
            **STACK_COMMANDS}  # fmt: skip
#: Commands are latest-wins: a short keep-last queue, so that nothing waits in DDS to go stale.
COMMAND_QOS_DEPTH = 10
#: How the node is driven (the ``executor`` parameter, read by ``main``):
#: ``deadline``: the main thread ticks at absolute deadlines of the wall clock and a
#: SingleThreadedExecutor in a second thread serves subscriptions, the service and diagnostics
#: (under ``use_sim_time`` the ticks follow ``/clock`` through a timer, as ``single`` does);
#: ``single``: one SingleThreadedExecutor runs everything, the tick being an rclpy timer.
#: rclpy's EventsExecutor is not offered: with the Jazzy wheels its timers never fired and it
#: ignored SIGINT and SIGTERM (docs/ros.md, "Rate").
EXECUTORS = ("deadline", "single")

#: The node's own parameters: (name, default, description, valid range or choices). All read-only.
NODE_PARAMETERS = (
    ("physics_rate_hz", 1000.0, "fixed physics step rate [Hz]", (100.0, 20000.0)),
    ("publish_rate_hz", 250.0, "joint-state publish rate [Hz], at most physics_rate_hz",
     (1.0, 2000.0)),
    ("joint_names", DEFAULT_JOINT_NAMES, "JointState names: piston, link, flap", None),
    ("integrator", "rk4", "fixed-step method of force mode", None),
    ("force_method", "virtual-work",
     "inverse-dynamics formulation: newton-euler, lagrange, virtual-work", None),
    ("force_limit", 2.0e4, "largest accepted |force command| [N]", (1.0, 1.0e6)),
    ("max_catch_up_steps", 200, "physics steps per tick before the simulation drops time",
     (1, 100000)),
    ("frame_id", "drs_base", "frame of ~/markers: the seed's ground frame (x rearwards, y up)",
     None),
    ("markers_rate_hz", 30.0, "~/markers (and rerun drawing) rate [Hz], computed only when used",
     (0.1, 1000.0)),
    ("diagnostics_window", 5.0, "diagnostics report the troubles of the last this many s [s]",
     (0.1, 3600.0)),
    ("executor", "deadline",
     "deadline (ticks on absolute deadlines, executor thread for the rest) or single", EXECUTORS),
    ("bag_path", "", "MCAP bag directory ('' = no bag)", None),
    ("rrd_path", "", "rerun .rrd file ('' = none)", None),
    ("rerun_connect", "", "stream to a running rerun viewer on loopback, e.g. "
     "rerun+http://127.0.0.1:9876/proxy ('' = none)", None),
    ("flush_period", 0.5, "MCAP flush period [s]", (0.01, 10.0)),
    ("model_params_file", "", "TOML/YAML file of DRSParams overrides", None),
) + STACK_PARAMETERS  # fmt: skip
#: Without /clock for this long under use_sim_time, the node says so (wall time) [s].
CLOCK_WAIT_WARNING_S = 2.0
#: A wall clock that moves this much [s] more or less than the steady clock between two ticks
#: has jumped (NTP slews far slower: 0.5 ms/s at most).
CLOCK_JUMP_THRESHOLD_S = 0.01
#: How often [s] a thread holding the GIL offers it to the others (see main).
GIL_SWITCH_INTERVAL_S = 0.0005
#: Bytes of a malformed command kept (hex) in its effect record, for forensics.
MALFORMED_BYTES_KEPT = 4096


class StartupError(DRSError):
    """The node refuses to start: a parameter or a recording path is wrong (the reason says)."""


@dataclasses.dataclass
class PendingCommand:
    """A command received and recorded, waiting for the next physics step (newest wins)."""

    key: str
    topic: str
    msg: object  # the decoded message (only messages that decode are ever pending)
    sequence: int | None
    received_ns: int
    prepared: object = None  # commands.prepare's result (a trajectory's plan)
    #: sequence numbers of the older commands of the topic this one replaced before a step
    superseded: list = dataclasses.field(default_factory=list)


class TroubleWindow:
    """Troubles (refusals, missed deadlines, superseded commands...) of the last ``window_s``
    seconds of node time, for diagnostics that recover once the trouble is over."""

    def __init__(self, window_s: float) -> None:
        self.window_ns = int(window_s * 1e9)
        self._events: collections.deque[tuple[int, str, str]] = collections.deque()

    def add(self, now_ns: int, kind: str, reason: str) -> None:
        self._events.append((now_ns, kind, reason))

    def recent(self, now_ns: int) -> dict[str, tuple[int, str]]:
        """kind -> (count in the window, last reason)."""
        while self._events and now_ns - self._events[0][0] > self.window_ns:
            self._events.popleft()
        out: dict[str, tuple[int, str]] = {}
        for _t, kind, reason in self._events:
            out[kind] = (out.get(kind, (0, ""))[0] + 1, reason)
        return out


class DRSNode(Node):
    """The DRS actuator node. Keyword arguments go to :class:`rclpy.node.Node`.

    Its life has the stages of a ROS 2 managed node, which :class:`ManagedDRSNode` exposes over
    the standard lifecycle services; unmanaged (the default) it configures and activates itself
    in the constructor:

    * :meth:`configure`: validate the parameters, build the actuator, create the publishers and
      open the recorders (a bad value or path raises, with the reason, leaving nothing behind);
    * :meth:`activate`: create the command subscriptions, the service and the timers;
    * :meth:`deactivate`: remove them again: the actuator holds its state, nothing is published;
    * :meth:`cleanup`: finish the recordings and drop the publishers and the actuator.
    """

    def __init__(self, *, tick_timer: bool = True, managed: bool = False, **kwargs) -> None:
        """``tick_timer=False``: the caller calls :meth:`tick` (see :func:`run_deadline_loop`);
        ``managed=True``: stay unconfigured until :meth:`configure` is called."""
        super().__init__("drs", **kwargs)
        # callbacks may run in an executor thread while the main thread ticks
        self._lock = threading.Lock()
        self._declare_parameters()
        self._wall_clock = not self.get_parameter("use_sim_time").value
        self._tick_timer = tick_timer
        self.configured = self.active = False
        self.callback_errors = 0
        self.recorder = self.rerun = None
        self.timer = self.diag_timer = self.clock_watch = None
        self.sub_stroke = self.sub_force = self.sub_trajectory = self.srv_drs = None
        self.sub_drs_events = None
        if not managed:
            self.configure()
            self.activate()

    # ---- life stages ---------------------------------------------------------------------------
    def configure(self) -> None:
        """Validate the parameters, build the actuator and the publishers, open the recorders."""
        self.params = self._model_params()
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
        self.sim = ActuatorSim(
            self.params,
            dt=self.physics_dt,
            force_limit=gp("force_limit").value,
            integrator=gp("integrator").value,
            force_method=gp("force_method").value,
        )
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
        self._own_publishers = (
            self.pub_joints,
            self.pub_force,
            self.pub_gap,
            self.pub_accel,
            self.pub_reactions,
            self.pub_markers,
            self.pub_diag,
            self.pub_events,
        )
        self.service_name = self.resolve_service_name("~/drs")
        # resolved names (e.g. /drs/piston_force), fixed for the node's life: the recording keys
        self.topics = {pub: pub.topic_name for pub in self._own_publishers}
        self.command_topics = {key: self.resolve_topic_name(f"~/{key}") for key in COMMANDS}
        # ---- issue 20 layer (drs_ros.stack): description, TF, the action, JointState commands
        self.stack = StackLayer(self, NodeHooks(
            event=lambda source, outcome, level, reason, values, now: self._event(
                source, outcome, level, reason, None, values, now),
            record=self._record, receive=self._receive, now_ns=self._now_ns))
        self.command_topics.update(self.stack.command_topics)
        # ----
        self._serialize = {
            cls: cdr.serializer(cls) for cls in (JointState, DiagnosticArray, MarkerArray)
        }
        self._pack_float64 = cdr.flat_packer(Float64)
        # a command is taken only as its exact CDR (plus transport padding), what every reader
        # of the bag decodes; a trajectory is read in place (rclpy's decoder would hold the GIL
        # for ~100 ms on 10,000 points, a stall of the real-time tick)
        self._decode = {key: functools.partial(cdr.decode_exact, msg_class=cls)
                        for key, cls in COMMANDS.items()}  # fmt: skip
        self._decode["trajectory_cmd"] = read_joint_trajectory
        self._joint_state = JointState(name=self.joint_names)  # filled in place at each publish
        self._listened = {self.pub_reactions: False, self.pub_markers: False}

        # counters for diagnostics (cumulative) and the window of recent troubles
        self.refused = 0
        self.accepted = 0
        self.superseded = 0
        self.received = 0
        self.last_refusal = ""
        self.refusals: collections.deque[str] = collections.deque(maxlen=100)
        self.missed_deadlines = 0
        self.dropped_steps = 0
        self.ticks = 0
        self.recording_error = ""
        self.troubles = TroubleWindow(gp("diagnostics_window").value)
        self._pending: dict[str, PendingCommand] = {}
        self._last_tick_ns: int | None = None
        self._last_tick_mono: int | None = None
        self.clock_jumps = 0
        self._last_markers_t: float | None = None
        self._last_still_t: float | None = None
        self._t0_ns: int | None = None
        self._cpu = {"model": 0.0, "publish": 0.0, "record": 0.0}
        self._started_wall = time.monotonic()
        self._clock_warned = False

        # all paths are checked before any file is created; a failure removes what was made
        self._open_recordings()
        try:
            self._register_recorded_topics()
        except Exception:
            self.discard_recordings()
            raise
        self.stack.start(self._now_ns())  # issue 20 layer: description and static TF, once
        self.configured = True
        self.get_logger().info(
            f"drs node configured: physics {physics_hz:g} Hz, publish {publish_hz:g} Hz, stroke "
            f"[{self.sim.s_min:.6g}, {self.sim.s_max:.6g}] m"
        )

    def activate(self) -> None:
        """Take commands and publish: the command subscriptions, the service, the timers."""
        cmd_qos = QoSProfile(depth=COMMAND_QOS_DEPTH)
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
        self.stack.activate()  # issue 20 layer: JointState commands, goals taken
        self.active = True

    def deactivate(self) -> None:
        """Stop taking commands and publishing; the actuator holds its state (no time passes)."""
        self.active = False
        self.stack.deactivate()  # issue 20 layer: goals aborted, no JointState commands
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
        self.stack.cleanup()  # issue 20 layer
        self.close_recordings()
        self.recorder = self.rerun = None
        for pub in self._own_publishers:
            self.destroy_publisher(pub)
        self.configured = False

    @property
    def service_event_topic(self) -> str:
        return f"{self.service_name}/_service_event"

    # ---- parameters ----------------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        known = [name for name, *_ in NODE_PARAMETERS]
        # and the ones rclpy declares itself
        known += [f"model.{name}" for name in NUMERIC_FIELDS]
        known += [name for name in self._parameters if name not in known]
        # rclpy keeps the --ros-args / parameter_overrides values here before they are declared:
        # the only place a misspelt name (never declared, silently ignored) can be seen
        overrides = self._parameter_overrides
        self._given_parameters = frozenset(overrides)
        for name in overrides:
            if name not in known and not name.startswith("qos_overrides."):
                close = difflib.get_close_matches(name, known, n=1, cutoff=0.5)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise StartupError(f"unknown parameter {name!r}{hint} (known: {', '.join(known)})")
        defaults = DRSParams()
        table = [*NODE_PARAMETERS] + [
            (f"model.{name}", float(getattr(defaults, name)), f"DRSParams.{name} (SI)", None)
            for name in NUMERIC_FIELDS
        ]
        for name, default, description, valid in table:
            desc = ParameterDescriptor(description=description, read_only=True)
            if isinstance(default, float):
                given = overrides.get(name)
                if given is not None and given.type_ == Parameter.Type.INTEGER:
                    # -p rate:=500 means 500.0: an integer is a valid double
                    overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(given.value))
                if isinstance(valid, tuple):
                    desc.floating_point_range = [
                        FloatingPointRange(from_value=valid[0], to_value=valid[1], step=0.0)
                    ]
            elif isinstance(valid, tuple) and isinstance(default, int):
                desc.integer_range = [IntegerRange(from_value=valid[0], to_value=valid[1], step=1)]
            elif isinstance(valid, tuple):
                desc.additional_constraints = f"one of {', '.join(valid)}"
            self.declare_parameter(
                name, list(default) if isinstance(default, tuple) else default, desc
            )
            if isinstance(valid, tuple) and isinstance(default, str):
                value = self.get_parameter(name).value
                if value not in valid:
                    raise StartupError(f"{name} must be one of {list(valid)}, got {value!r}")

    def _model_params(self) -> DRSParams:
        """The model's parameters: the seed's, then ``model_params_file``'s, then every
        ``model.*`` parameter given to the node (``-p`` or a ROS ``--params-file``), whatever
        its value: a value given is the value used, even when it equals a default."""
        path = self.get_parameter("model_params_file").value
        base = from_file(path) if path else DRSParams()
        given = {name: self.get_parameter(f"model.{name}").value for name in NUMERIC_FIELDS
                 if f"model.{name}" in self._given_parameters}  # fmt: skip
        if path:
            over = [f"model.{k} {v!r} over {getattr(base, k)!r}" for k, v in given.items()
                    if v != getattr(base, k)]  # fmt: skip
            if over:
                self.get_logger().info(f"parameters given win over {path}: {', '.join(over)}")
        return from_dict(given, base=base) if given else base

    def effective_parameters(self) -> list[Parameter]:
        """Every node parameter, the ``model.*`` ones at the values the model runs with (a
        ``model_params_file`` included): what a re-run needs."""
        out = []
        for name in sorted(self._parameters):
            if name.startswith("model."):
                value = float(getattr(self.params, name.removeprefix("model.")))
                out.append(Parameter(name, Parameter.Type.DOUBLE, value))
            else:
                out.append(self.get_parameter(name))
        return out

    # ---- recordings ----------------------------------------------------------------------------
    def _open_recordings(self) -> None:
        """Check both paths, then create both recorders; on any failure remove what was made."""
        from .recording import McapRecorder, RecordingError, check_new_bag

        bag = self.get_parameter("bag_path").value
        rrd = self.get_parameter("rrd_path").value
        live = self.get_parameter("rerun_connect").value
        if bag:
            check_new_bag(bag)
        if rrd or live:
            from .rerun_log import check_connect_url, check_new_rrd

            if rrd:
                check_new_rrd(rrd)
            if live:
                check_connect_url(live)
        made_dir = bool(bag) and not Path(bag).exists()
        try:
            if bag:
                self.recorder = McapRecorder(
                    bag, flush_period=self.get_parameter("flush_period").value
                )
            if rrd or live:
                from .rerun_log import RerunRecorder

                # the mechanism drawn as often as ~/markers draws it; the series at every sample
                self.rerun = RerunRecorder(
                    rrd or None,
                    self.params,
                    connect_url=live or None,
                    max_draw_hz=self.markers_rate_hz,
                )
        except Exception as exc:
            self._made_bag_dir = made_dir
            self.discard_recordings()
            if isinstance(exc, DRSError):
                raise
            raise RecordingError(f"cannot start the recordings: {exc}") from exc
        self._made_bag_dir = made_dir

    def discard_recordings(self) -> None:
        """Close and delete the recordings of a node that fails to start: nothing is left."""
        if self.recorder is not None:
            self.recorder.discard()
            if self._made_bag_dir:
                shutil.rmtree(self.recorder.bag_dir, ignore_errors=True)
            self.recorder = None
        if self.rerun is not None:
            self.rerun.discard()
            self.rerun = None

    def _register_recorded_topics(self) -> None:
        if self.recorder is None:
            return
        register = self.recorder.register_topic
        for pub, topic in self.topics.items():
            register(topic, pub.msg_type, qos=QoSProfile(depth=100 if pub is self.pub_events
                                                         else QOS_DEPTH))  # fmt: skip
        for key, topic in self.command_topics.items():
            register(topic, COMMANDS[key], qos=QoSProfile(depth=COMMAND_QOS_DEPTH))
        register(self.service_event_topic, SetBool.Event, qos=QoSProfile(depth=100))
        for topic, msg_type, qos in self.stack.recorded_topics():  # issue 20 layer
            register(topic, msg_type, qos=qos)
        register("/parameter_events", ParameterEvent, qos=QoSProfile(depth=1000))
        now = self._now_ns()
        event = parameter_event_msg(self.get_fully_qualified_name(), self.effective_parameters(),
                                    now)  # fmt: skip
        self.recorder.write("/parameter_events", event, now)

    def _record(self, topic: str, data: bytes, now_ns: int) -> int | None:
        """Append exact bytes to the bag; returns the sequence number (None: not recorded)."""
        if self.recorder is None or self.recording_error:
            return None
        try:
            return self.recorder.write(topic, data, log_time_ns=now_ns)
        except Exception as exc:  # noqa: BLE001 - a failing disk must not stop the actuator
            self.recording_error = f"{type(exc).__name__}: {exc}"
            self.get_logger().error(f"recording stopped: {self.recording_error}")
            return None

    def close_recordings(self) -> None:
        """Finish the MCAP bag and the rerun file (idempotent)."""
        if self.rerun is not None:
            try:
                self.rerun.close()
            except Exception as exc:  # noqa: BLE001
                self.get_logger().error(f"rerun close failed: {exc}")
        if self.recorder is not None:
            try:
                self.recorder.finish()
            except Exception as exc:  # noqa: BLE001
                self.get_logger().error(f"bag finish failed: {exc}")

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
            msg = self._decode[key](data)
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
            cmd = PendingCommand(key, topic, msg, self._record(topic, data, now), now, prepared)
            if refusal is not None:
                self._refuse_command(cmd, refusal, now)
                return
            older = self._pending.get(key)
            if older is not None:  # counted and recorded (one record per step) when it comes
                cmd.superseded = older.superseded
                cmd.superseded.append(older.sequence)
            self._pending[key] = cmd

    def _refuse_malformed(
        self, topic: str, msg_type, data: bytes, exc: Exception, now_ns: int
    ) -> None:
        """Bytes that are no ``msg_type``: refused with the reason; the bytes themselves go into
        the effect record (hex, for forensics), never onto the typed topic."""
        type_name = f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"
        why = str(exc).split(", at /")[0]  # rmw appends its C++ source location
        reason = self._refuse(
            topic,
            f"<{len(data)} bytes>",
            f"not a valid {type_name} ({type(exc).__name__}: {why})",
            now_ns,
        )
        self._event(topic, REFUSED, DiagnosticStatus.WARN, reason, None, {
            "value": f"<{len(data)} bytes>", "malformed": "true", "size": len(data),
            "sha256": hashlib.sha256(data).hexdigest(),
            "bytes_hex": data[:MALFORMED_BYTES_KEPT].hex(),
        }, now_ns)  # fmt: skip

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

    def _refuse_command(self, cmd: PendingCommand, exc: Exception, now_ns: int) -> None:
        value = commands.describe(cmd.key, cmd.msg)
        why = str(exc) if isinstance(exc, DRSError) else f"{type(exc).__name__}: {exc}"
        reason = self._refuse(cmd.key, value, why, now_ns)
        self._event(
            cmd.topic, REFUSED, DiagnosticStatus.WARN, reason, cmd, {"value": repr(value)}, now_ns
        )

    def _refuse(self, what: str, value, reason: str, now_ns: int) -> str:
        self.refused += 1
        self.last_refusal = f"{what} {value!r} refused: {reason}"
        self.refusals.append(self.last_refusal)
        self.troubles.add(now_ns, REFUSED, self.last_refusal)
        self.get_logger().warning(self.last_refusal, throttle_duration_sec=1.0)
        return self.last_refusal

    def _event(
        self,
        source: str,
        outcome: str,
        level: bytes,
        reason: str,
        cmd: PendingCommand | None,
        values: dict,
        now_ns: int,
    ) -> None:
        """One record of the effect log: what happened, at which simulated instant. ``now_ns``
        is the node time of the tick or callback it happens in (its log time in the bag)."""
        record = {"sim_time": repr(self.sim.t), "step": self.sim.steps}
        if cmd is not None:
            record["sequence"] = "" if cmd.sequence is None else cmd.sequence
            record["received_ns"] = cmd.received_ns
        record.update(values)
        stamp = now_ns if self._t0_ns is None else self._t0_ns + int(round(self.sim.t * 1e9))
        msg = command_event_msg(stamp, source, outcome, level, reason, record)
        data = self._serialize[DiagnosticArray](msg)
        self.pub_events.publish(data)
        self._record(self.topics[self.pub_events], data, now_ns)

    def _on_drs(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        with self._lock:
            return self._on_drs_locked(request, response)

    def _on_drs_locked(self, request, response):
        # a service call takes effect at once: the simulation is between two physics steps
        now = self._now_ns()
        self._apply_pending(now)  # commands that arrived earlier act first, as they would have
        value = commands.describe(commands.SERVICE_KEY, request)
        try:
            seg = commands.apply(self.sim, commands.SERVICE_KEY, request, self.joint_names[0])
        except Exception as exc:  # noqa: BLE001 - what a request carries never stops the node
            why = str(exc) if isinstance(exc, DRSError) else f"{type(exc).__name__}: {exc}"
            response.success = False
            response.message = self._refuse("drs", value, why, now)
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
        # an event ends in a string, so the transport may have padded it (drs_ros.cdr.exact_bytes)
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
        mono = time.monotonic_ns()
        if self._t0_ns is None:
            self._t0_ns = now - int(round(self.sim.t * 1e9))
            self._event(CLOCK, CLOCK, DiagnosticStatus.OK, "", None, {"t0_ns": self._t0_ns}, now)
        elif self._last_tick_ns is not None:
            self._check_clock_jump(now, mono)
        if (
            self._last_tick_ns is not None
            and now - self._last_tick_ns > 1.5e9 * self.publish_period
        ):
            self.missed_deadlines += 1
            self.troubles.add(
                now,
                "missed_deadline",
                f"tick {(now - self._last_tick_ns) * 1e-6:.1f} ms after the last",
            )
        self._last_tick_ns, self._last_tick_mono = now, mono
        self.ticks += 1
        t = time.process_time()
        if self._pending:
            self._apply_pending(now)
        target = (now - self._t0_ns) * 1e-9
        due = int(math.floor((target - self.sim.t) / self.physics_dt + 1e-9))
        if due > self.max_catch_up:
            # too far behind (a stall): drop the excess instead of spiralling
            dropped = due - self.max_catch_up
            self.dropped_steps += dropped
            self.troubles.add(now, "dropped_steps", f"{dropped} physics steps dropped")
            self._t0_ns += int(round(dropped * self.physics_dt * 1e9))
            self._event(
                CLOCK,
                CLOCK,
                DiagnosticStatus.WARN,
                f"{dropped} steps dropped",
                None,
                {"t0_ns": self._t0_ns},
                now,
            )
            due = self.max_catch_up
        try:
            self.sim.advance(max(due, 0))
        except DRSError as exc:  # the model refuses to go on: hold where it is and say why
            reason = self._refuse("step", self.sim.mode, str(exc), now)
            s_hold = float(min(max(self.sim.state.q[0], self.sim.s_min), self.sim.s_max))
            self.sim.reset(self.sim.t, s_hold)
            self._event(
                RESET, RESET, DiagnosticStatus.WARN, reason, None, {"stroke": repr(s_hold)}, now
            )
        self._cpu["model"] += time.process_time() - t
        if due > 0 or self.ticks == 1:  # publish new states only (stamps strictly increase)
            self._publish(now)

    def _check_clock_jump(self, now: int, mono: int) -> None:
        """A node clock that jumps (the system clock stepped by NTP or by hand; ``/clock`` going
        back, as ``drs-bag play --loop --clock`` does) moves the clock origin by the jump, as
        ROS 2's time-jump callbacks would: the simulation goes on from its state, in step with
        the new clock, and the jump is recorded. Without it, a clock stepped back froze the
        simulation until the clock caught up again."""
        if self._wall_clock:  # the wall clock against the steady one: any difference is a jump
            jump = (now - self._last_tick_ns) - (mono - self._last_tick_mono)
            if abs(jump) < CLOCK_JUMP_THRESHOLD_S * 1e9:
                return
        else:  # /clock may run at any rate: only a step back is a jump
            if now >= self._last_tick_ns:
                return
            jump = now - self._last_tick_ns
        self._t0_ns += jump
        self.clock_jumps += 1
        way = "forward" if jump > 0 else "back"
        reason = f"node clock jumped {way} by {abs(jump) * 1e-9:.6g} s"
        self.troubles.add(now, "clock_jump", reason)
        self.get_logger().warning(f"{reason}: the simulation goes on from its state")
        self._event(
            CLOCK,
            CLOCK,
            DiagnosticStatus.WARN,
            reason,
            None,
            {"t0_ns": self._t0_ns, "jump_ns": jump},
            now,
        )
        self._last_tick_ns = now  # no missed deadline for the jump itself

    def _publish(self, now_ns: int) -> None:
        t = time.process_time()
        st = self.sim.state
        stamp = self._t0_ns + int(round(st.t * 1e9))
        pack = self._pack_float64
        out = [
            (self.pub_joints, self._serialize[JointState](
                joint_state_msg(st, self.joint_names, stamp, self._joint_state))),
            (self.pub_force, pack(st.piston_force)),
            (self.pub_gap, pack(st.gap)),
            (self.pub_accel, pack(st.qdd[0])),
        ]  # fmt: skip
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
        self.stack.publish(st, stamp, now_ns)  # issue 20 layer: /tf, the action's feedback
        if self.rerun is not None and not self.recording_error:
            try:
                self.rerun.log_state(st.t, st.q, st.piston_force)
            except Exception as exc:  # noqa: BLE001
                self.recording_error = f"rerun: {exc}"
        self._cpu["record"] += time.process_time() - t1

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

    def diagnostics_values(self) -> dict[str, object]:
        st = self.sim.state
        rec = "off"
        if self.recording_error:
            rec = f"error: {self.recording_error}"
        elif self.recorder is not None:
            s = self.recorder.stats()
            rec = f"{s.message_count} messages, {s.flush_count} flushes"
        return {
            "mode": st.mode,
            "sim_time_s": f"{st.t:.6f}",
            "stroke_m": f"{st.q[0]:.9g}",
            "gap_m": f"{st.gap:.9g}",
            "piston_force_N": f"{st.piston_force:.6g}",
            "at_stop": st.at_stop or "none",
            "dead_centre_distance_m": f"{st.dead_centre_distance:.6g}",
            "transmission_cos": f"{st.transmission:.4f}",
            "received_commands": self.received,
            "accepted_commands": self.accepted,
            "refused_commands": self.refused,
            "superseded_commands": self.superseded,
            "last_refusal": self.last_refusal or "none",
            "missed_deadlines": self.missed_deadlines,
            "dropped_steps": self.dropped_steps,
            "clock_jumps": self.clock_jumps,
            "callback_errors": self.callback_errors,
            "ticks": self.ticks,
            "recording": rec,
            "cpu_model_s": f"{self._cpu['model']:.3f}",
            "cpu_publish_s": f"{self._cpu['publish']:.3f}",
            "cpu_record_s": f"{self._cpu['record']:.3f}",
        }

    def diagnostics_level(self, now_ns: int) -> tuple[bytes, str]:
        """OK, WARN or ERROR with the reason, from the troubles of the recent window only."""
        if self.recording_error:
            return DiagnosticStatus.ERROR, f"recording failed: {self.recording_error}"
        recent = self.troubles.recent(now_ns)
        if not recent:
            return DiagnosticStatus.OK, f"mode {self.sim.mode}"
        window = self.troubles.window_ns * 1e-9
        parts = [f"{n} {kind.replace('_', ' ')} (last: {reason})"
                 for kind, (n, reason) in sorted(recent.items())]  # fmt: skip
        return DiagnosticStatus.WARN, f"in the last {window:g} s: " + "; ".join(parts)

    def executor_error(self, exc: Exception) -> None:
        """A callback (or the middleware taking a message for it) raised: counted, reported in
        diagnostics, and the node goes on."""
        reason = f"{type(exc).__name__}: {str(exc).split(', at /')[0]}"
        with self._lock:
            self.callback_errors += 1
            if self.configured:
                self.troubles.add(self._now_ns(), "callback_error", reason)
        self.get_logger().error(
            f"a callback failed, the node goes on: {reason}", throttle_duration_sec=1.0
        )

    def _on_diagnostics(self) -> None:
        now = self._now_ns()
        with self._lock:  # the main thread may be stepping the actuator (deadline executor)
            level, message = self.diagnostics_level(now)
            values = self.diagnostics_values()
        msg = diagnostics_msg(now, self.get_name(), level, message, values)
        data = self._serialize[DiagnosticArray](msg)
        self.pub_diag.publish(data)
        self._record(self.topics[self.pub_diag], data, now)


class ManagedDRSNode(LifecycleNodeMixin, DRSNode):
    """The DRS node as a ROS 2 managed (lifecycle) node: ``drs-node --managed``.

    It starts unconfigured; a lifecycle manager drives it over the standard ``~/change_state``
    and ``~/get_state`` services: configure (validate the parameters, open the recorders),
    activate (subscriptions, service, timers), deactivate (hold, publish nothing), cleanup
    (finish the recordings), shutdown. A transition that fails logs the reason and returns
    FAILURE, as the lifecycle design says.
    """

    def __init__(self, **kwargs) -> None:
        DRSNode.__init__(self, managed=True, **kwargs)
        LifecycleNodeMixin.__init__(self, enable_communication_interface=True)

    def _transition(self, name: str, action) -> TransitionCallbackReturn:
        try:
            action()
        except (DRSError, ParameterException) as exc:
            self.get_logger().error(f"{name} failed: {exc}")
            if name == "configure":
                self.discard_recordings()
            return TransitionCallbackReturn.FAILURE
        return TransitionCallbackReturn.SUCCESS

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("configure", self.configure)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("activate", self.activate)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("deactivate", self.deactivate)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("cleanup", self.cleanup)

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("shutdown", self.cleanup if self.configured else lambda: None)

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        return self._transition("error", self.cleanup if self.configured else lambda: None)


class StopRequest:
    """A stop asked for by SIGINT or SIGTERM (or by a caller), taken at a tick boundary.

    rclpy's own signal handlers are not installed (``SignalHandlerOptions.NO``): Python's raise
    ``KeyboardInterrupt`` at any bytecode (between a bag write and its count, say), and rclpy's
    shut the context down under running callbacks. This handler only sets a flag, which the loops
    read between ticks; the stop then runs in order: the loops end, the executor thread is joined,
    the recordings are finished after the last write, the node is destroyed."""

    def __init__(self) -> None:
        self.requested = False  # a plain flag: setting it takes no lock a signal could interrupt
        self.signal_name = ""

    def __call__(self, signum=None, frame=None) -> None:
        if signum is not None:
            self.signal_name = signal.Signals(signum).name
        self.requested = True

    def install(self) -> None:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self)

    def ignore_further(self) -> None:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)


#: The longest a loop waits before it looks at the stop flag again [s].
STOP_POLL_S = 0.05


def spin_until_stopped(node: Node, executor, stop: StopRequest) -> None:
    """Run ``executor``'s callbacks until ``stop`` is requested or the context ends. A callback
    that raises is logged and counted, and the executor goes on: nothing a participant sends
    (a message the middleware cannot take, say) ends the node's service of the others."""
    while not stop.requested and executor.context.ok():
        try:
            executor.spin_once(timeout_sec=STOP_POLL_S)
        except ExternalShutdownException:
            return
        except Exception as exc:  # noqa: BLE001
            if not executor.context.ok():
                return
            note = getattr(node, "executor_error", None)
            if note is not None:
                note(exc)
            else:
                node.get_logger().error(f"callback failed: {type(exc).__name__}: {exc}")


def run_deadline_loop(node: DRSNode, stop: StopRequest, context=None) -> None:
    """Drive ``node`` until ``stop`` is requested: ticks at absolute deadlines of the wall clock
    in this thread, everything else in a SingleThreadedExecutor in a second thread, which is
    joined before this returns. A late tick is counted by the node; the deadlines then resume
    from now, so a stall does not cause a burst of catch-up ticks (the simulation catches up
    within one tick).

    Why: one rclpy timer at 250 Hz in a SingleThreadedExecutor rebuilds its wait set at every
    wake-up, which cost more than the physics, the publishing and the recording together
    (docs/ros.md, "Rate").
    """
    context = context or node.context
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    thread = threading.Thread(target=spin_until_stopped, args=(node, executor, stop),
                              name="drs-executor")  # fmt: skip
    thread.start()
    period_ns = int(round(node.publish_period * 1e9))
    deadline = time.monotonic_ns()
    try:
        while not stop.requested and context.ok():
            deadline += period_ns
            wait = deadline - time.monotonic_ns()
            while wait > 0 and not stop.requested:  # a long period still sees a stop soon
                time.sleep(min(wait * 1e-9, STOP_POLL_S))
                wait = deadline - time.monotonic_ns()
            if wait < -period_ns:
                deadline = time.monotonic_ns()  # late by more than a period: resume from now
            if stop.requested or not context.ok():
                break
            node.tick()
    finally:
        stop()  # the executor thread ends too, whatever ended this loop
        thread.join()
        executor.shutdown(timeout_sec=1.0)


def main(argv: list[str] | None = None) -> int:
    """Console script ``drs-node [--managed]`` (``--ros-args -p name:=value`` or
    ``--params-file FILE`` as usual). Returns 0 on SIGINT/SIGTERM, with both recordings
    finished; 2 when the parameters or the recording paths are refused (one line on stderr,
    nothing created)."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    args = list(sys.argv if argv is None else argv)
    managed = (
        "--managed" in args[: args.index("--ros-args")]
        if "--ros-args" in args
        else "--managed" in args
    )
    if managed:
        args.remove("--managed")
    stop = StopRequest()
    stop.install()  # before rclpy starts: a signal during start-up is a stop too
    # the executor thread's Python work (reading a large trajectory) hands the GIL to the
    # real-time tick within this [s] when the tick wakes up (CPython's default: 5 ms, more than
    # a publish period at 250 Hz)
    sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    rc = 0
    try:
        if managed:
            node = ManagedDRSNode()
        else:
            node = DRSNode(tick_timer=False)
        if (
            not managed
            and node.get_parameter("executor").value == "deadline"
            and node.timer is None
        ):
            run_deadline_loop(node, stop)
        else:
            if not managed and node.timer is None:  # executor 'single': the tick is a timer
                node.timer = node.create_timer(node.publish_period, node.tick)
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            spin_until_stopped(node, executor, stop)
            executor.shutdown(timeout_sec=1.0)
    except (DRSError, ParameterException) as exc:
        print(f"drs-node: refused to start: {exc}", file=sys.stderr)
        rc = 2
    finally:
        if node is not None:
            if node.configured:
                node.close_recordings()
            node.destroy_node()
        rclpy.try_shutdown()
    # the recordings are finished: a further SIGINT/SIGTERM (a second Ctrl-C) is ignored, not
    # left to interpreter shutdown, which restores the default action (killed: exit -2)
    stop.ignore_further()
    if stop.signal_name:
        print(f"drs-node: stopped by {stop.signal_name}, recordings finished", file=sys.stderr)
    return rc


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
