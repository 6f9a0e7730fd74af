"""The ``drs`` ROS 2 node: a thin adapter around :class:`drs_model.actuator.ActuatorSim`.

Topics (``~`` is the node namespace, ``/drs/...`` by default):

* ``~/stroke_cmd`` (in, std_msgs/Float64): move smoothly to this stroke [m];
* ``~/force_cmd`` (in, std_msgs/Float64): apply this piston force [N] from now on;
* ``~/trajectory_cmd`` (in, trajectory_msgs/JointTrajectory): follow the piston joint's points;
* ``~/drs`` (service, std_srvs/SetBool): true opens, false closes (the seed's times);
* ``/joint_states`` (sensor_msgs/JointState): piston [m, m/s, N], link and flap [rad, rad/s];
* ``~/piston_force``, ``~/flap_gap``, ``~/piston_acceleration`` (std_msgs/Float64): [N], [m],
  [m/s^2];
* ``~/joint_reactions`` (sensor_msgs/JointState): reactions by name, only while subscribed;
* ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, ~1 Hz): mode, dead centre, refusals...

The physics runs on a fixed simulated step (``physics_rate_hz``); one timer at ``publish_rate_hz``
catches the simulation up with the node clock (wall or ``/clock`` with ``use_sim_time``) and
publishes. Stamps are ``t0 + simulated time``, so they follow the node clock without its jitter.
Every command received is recorded, accepted or refused.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import os
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory

from drs_model.actuator import ActuatorSim
from drs_model.errors import DRSError
from drs_model.params import DRSParams, from_dict, from_file

from .check import DEFAULT_JOINT_NAMES  # the names the node publishes and the check assumes
from .conversions import (
    diagnostics_msg,
    float_msg,
    joint_state_msg,
    reactions_msg,
    trajectory_points,
)

QOS_DEPTH = 10

#: The node's own parameters: (name, default, description, valid range or None). All read-only.
NODE_PARAMETERS = (
    ("physics_rate_hz", 1000.0, "fixed physics step rate [Hz]", (100.0, 20000.0)),
    ("publish_rate_hz", 250.0, "joint-state publish rate [Hz]", (1.0, 2000.0)),
    ("joint_names", DEFAULT_JOINT_NAMES, "JointState names: piston, link, flap", None),
    ("integrator", "rk4", "fixed-step method of force mode", None),
    (
        "force_method",
        "virtual-work",
        "inverse-dynamics formulation: newton-euler, lagrange, virtual-work",
        None,
    ),
    ("force_limit", 2.0e4, "largest accepted |force command| [N]", (1.0, 1.0e6)),
    (
        "max_command_rate_hz",
        1000.0,
        "commands per topic beyond this rate are refused [Hz]",
        (1.0, 1.0e5),
    ),
    (
        "max_catch_up_steps",
        200,
        "physics steps per tick before the simulation drops time",
        (1, 100000),
    ),
    ("bag_path", "", "MCAP bag directory ('' = no bag)", None),
    ("rrd_path", "", "rerun .rrd file ('' = none)", None),
    ("flush_period", 0.5, "MCAP flush period [s]", (0.01, 10.0)),
    ("model_params_file", "", "TOML/YAML file of DRSParams overrides", None),
)
#: Command queues are deep so that a burst is received (and recorded) rather than dropped by DDS;
#: the node then refuses what exceeds max_command_rate_hz, with a reason.
COMMAND_QOS_DEPTH = 1000


def _float_range(lo: float, hi: float) -> list[FloatingPointRange]:
    return [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]


def _model_fields() -> list[dataclasses.Field]:
    return [f for f in dataclasses.fields(DRSParams) if not f.name.endswith("_outline")]


class DRSNode(Node):
    """The DRS actuator node. Keyword arguments go to :class:`rclpy.node.Node`."""

    def __init__(self, **kwargs) -> None:
        super().__init__("drs", **kwargs)
        self._declare_parameters()
        self.params = self._model_params()
        gp = self.get_parameter
        self.physics_dt = 1.0 / gp("physics_rate_hz").value
        self.publish_period = 1.0 / gp("publish_rate_hz").value
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
        self.min_command_interval_ns = int(1e9 / gp("max_command_rate_hz").value)

        qos = QoSProfile(depth=QOS_DEPTH)
        self.pub_joints = self.create_publisher(JointState, "/joint_states", qos)
        self.pub_force = self.create_publisher(Float64, "~/piston_force", qos)
        self.pub_gap = self.create_publisher(Float64, "~/flap_gap", qos)
        # JointState has no acceleration field; with it a bag replays the piston force exactly
        self.pub_accel = self.create_publisher(Float64, "~/piston_acceleration", qos)
        self.pub_reactions = self.create_publisher(JointState, "~/joint_reactions", qos)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", qos)
        cmd_qos = QoSProfile(depth=COMMAND_QOS_DEPTH)
        self.sub_stroke = self.create_subscription(
            Float64, "~/stroke_cmd", self._on_stroke, cmd_qos
        )
        self.sub_force = self.create_subscription(Float64, "~/force_cmd", self._on_force, cmd_qos)
        self.sub_trajectory = self.create_subscription(
            JointTrajectory, "~/trajectory_cmd", self._on_trajectory, cmd_qos
        )
        self.srv_drs = self.create_service(SetBool, "~/drs", self._on_drs)
        # resolved topic names (e.g. /drs/piston_force), fixed for the node's life: the recording
        # keys, looked up once instead of built per message
        self.topic = {
            entity: entity.topic_name
            for entity in (
                self.pub_joints, self.pub_force, self.pub_gap, self.pub_accel, self.pub_reactions,
                self.pub_diag, self.sub_stroke, self.sub_force, self.sub_trajectory,
            )
        }  # fmt: skip

        # counters for diagnostics
        self.refused = 0
        self.accepted = 0
        self.last_refusal = ""
        self.refusals: collections.deque[str] = collections.deque(maxlen=100)
        self.missed_deadlines = 0
        self.dropped_steps = 0
        self.ticks = 0
        self.recording_error = ""
        self._last_accept_ns: dict[str, int] = {}
        self._last_tick_ns: int | None = None
        self._t0_ns: int | None = None
        self._cpu = {"model": 0.0, "publish": 0.0, "record": 0.0}

        self.recorder = None
        self.rerun = None
        self._open_recordings(qos)

        self.timer = self.create_timer(self.publish_period, self._on_tick)
        self.diag_timer = self.create_timer(1.0, self._on_diagnostics)
        self.get_logger().info(
            f"drs node up: physics {1 / self.physics_dt:g} Hz, publish {1 / self.publish_period:g} "
            f"Hz, stroke [{self.sim.s_min:.6g}, {self.sim.s_max:.6g}] m"
        )

    # ---- parameters ----------------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        for name, default, description, valid in NODE_PARAMETERS:
            desc = ParameterDescriptor(description=description, read_only=True)
            if isinstance(valid, tuple) and isinstance(default, float):
                desc.floating_point_range = _float_range(*valid)
            elif isinstance(valid, tuple):
                desc.integer_range = [IntegerRange(from_value=valid[0], to_value=valid[1], step=1)]
            self.declare_parameter(
                name, list(default) if isinstance(default, tuple) else default, desc
            )
        defaults = DRSParams()
        for f in _model_fields():
            value = getattr(defaults, f.name)
            self.declare_parameter(
                f"model.{f.name}",
                float(value),
                ParameterDescriptor(description=f"DRSParams.{f.name} (SI)", read_only=True),
            )

    def _model_params(self) -> DRSParams:
        path = self.get_parameter("model_params_file").value
        base = from_file(path) if path else DRSParams()
        overrides = {}
        defaults = DRSParams()
        for f in _model_fields():
            value = self.get_parameter(f"model.{f.name}").value
            if value != float(getattr(defaults, f.name)):
                overrides[f.name] = value
        return from_dict(overrides, base=base) if overrides else base

    # ---- recordings ----------------------------------------------------------------------------
    def _open_recordings(self, qos: QoSProfile) -> None:
        bag = self.get_parameter("bag_path").value
        rrd = self.get_parameter("rrd_path").value
        if bag:
            from .recording import McapRecorder

            self.recorder = McapRecorder(
                bag, overwrite=False, flush_period=self.get_parameter("flush_period").value
            )
            for entity, topic in self.topic.items():
                depth = COMMAND_QOS_DEPTH if topic.endswith("_cmd") else QOS_DEPTH
                self.recorder.register_topic(topic, entity.msg_type, qos=QoSProfile(depth=depth))
        if rrd:
            from .rerun_log import RerunRecorder

            self.rerun = RerunRecorder(rrd, self.params)

    def _record(self, topic: str, msg, now_ns: int) -> None:
        if self.recorder is None or self.recording_error:
            return
        t = time.process_time()
        try:
            self.recorder.write(topic, msg, log_time_ns=now_ns)
        except Exception as exc:  # noqa: BLE001 - a failing disk must not stop the actuator
            self.recording_error = f"{type(exc).__name__}: {exc}"
            self.get_logger().error(f"recording stopped: {self.recording_error}")
        self._cpu["record"] += time.process_time() - t

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
        return self.get_clock().now().nanoseconds

    def _flood(self, key: str, now_ns: int) -> bool:
        last = self._last_accept_ns.get(key)
        if last is not None and 0 <= now_ns - last < self.min_command_interval_ns:
            return True
        self._last_accept_ns[key] = now_ns
        return False

    def _refuse(self, what: str, value, reason: str) -> str:
        self.refused += 1
        self.last_refusal = f"{what} {value!r} refused: {reason}"
        self.refusals.append(self.last_refusal)
        self.get_logger().warning(self.last_refusal, throttle_duration_sec=1.0)
        return self.last_refusal

    def _command(self, key: str, sub, msg, apply) -> None:
        now = self._now_ns()
        self._record(self.topic[sub], msg, now)
        if self._flood(key, now):
            self._refuse(key, msg.data, "command flood (max_command_rate_hz)")
            return
        try:
            apply(msg.data)
        except DRSError as exc:
            self._refuse(key, msg.data, str(exc))
            return
        self.accepted += 1

    def _on_stroke(self, msg: Float64) -> None:
        self._command("stroke_cmd", self.sub_stroke, msg, self.sim.command_stroke)

    def _on_force(self, msg: Float64) -> None:
        self._command("force_cmd", self.sub_force, msg, self.sim.command_force)

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        now = self._now_ns()
        self._record(self.topic[self.sub_trajectory], msg, now)
        summary = f"<{len(msg.points)} points>"
        if self._flood("trajectory_cmd", now):
            self._refuse("trajectory_cmd", summary, "command flood (max_command_rate_hz)")
            return
        try:
            times, strokes, rates = trajectory_points(msg, self.joint_names[0])
            self.sim.command_trajectory(times, strokes, rates)
        except DRSError as exc:
            self._refuse("trajectory_cmd", summary, str(exc))
            return
        self.accepted += 1

    def _on_drs(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        try:
            seg = self.sim.command_drs(bool(request.data))
        except DRSError as exc:
            response.success = False
            response.message = self._refuse("drs", request.data, str(exc))
            return response
        self.accepted += 1
        response.success = True
        response.message = (
            f"{'opening' if request.data else 'closing'} to {seg.evaluate(seg.t1)[0]:.6g} m "
            f"in {seg.duration:g} s"
        )
        return response

    # ---- the loop ------------------------------------------------------------------------------
    def _on_tick(self) -> None:
        now = self._now_ns()
        if now == 0:  # use_sim_time before the first /clock message
            return
        if self._t0_ns is None:
            self._t0_ns = now - int(round(self.sim.t * 1e9))
        if (
            self._last_tick_ns is not None
            and now - self._last_tick_ns > 1.5e9 * self.publish_period
        ):
            self.missed_deadlines += 1
        self._last_tick_ns = now
        self.ticks += 1
        target = (now - self._t0_ns) * 1e-9
        t = time.process_time()
        due = int(math.floor((target - self.sim.t) / self.physics_dt + 1e-9))
        if due > self.max_catch_up:
            # too far behind (a stall): drop the excess instead of spiralling
            dropped = due - self.max_catch_up
            self.dropped_steps += dropped
            self._t0_ns += int(round(dropped * self.physics_dt * 1e9))
            due = self.max_catch_up
        try:
            for _ in range(max(due, 0)):
                self.sim.step()
        except DRSError as exc:  # the model refuses to go on: hold where it is and say why
            self._refuse("step", self.sim.mode, str(exc))
            self.sim.reset(
                self.sim.t, float(min(max(self.sim.state.q[0], self.sim.s_min), self.sim.s_max))
            )
        self._cpu["model"] += time.process_time() - t
        if due > 0 or self.ticks == 1:  # publish new states only (stamps strictly increase)
            self._publish(now)

    def _publish(self, now_ns: int) -> None:
        t = time.process_time()
        st = self.sim.state
        stamp = self._t0_ns + int(round(st.t * 1e9))
        out = [
            (self.pub_joints, joint_state_msg(st, self.joint_names, stamp)),
            (self.pub_force, float_msg(st.piston_force)),
            (self.pub_gap, float_msg(st.gap)),
            (self.pub_accel, float_msg(st.qdd[0])),
        ]
        if self.pub_reactions.get_subscription_count() > 0:
            out.append((self.pub_reactions, reactions_msg(self.sim.reactions(), stamp)))
        for pub, msg in out:
            pub.publish(msg)
        self._cpu["publish"] += time.process_time() - t
        for pub, msg in out:
            self._record(self.topic[pub], msg, now_ns)
        if self.rerun is not None and not self.recording_error:
            t = time.process_time()
            try:
                self.rerun.log_state(st.t, st.q, st.piston_force)
            except Exception as exc:  # noqa: BLE001
                self.recording_error = f"rerun: {exc}"
            self._cpu["record"] += time.process_time() - t

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
            "accepted_commands": self.accepted,
            "refused_commands": self.refused,
            "last_refusal": self.last_refusal or "none",
            "missed_deadlines": self.missed_deadlines,
            "dropped_steps": self.dropped_steps,
            "ticks": self.ticks,
            "recording": rec,
            "cpu_model_s": f"{self._cpu['model']:.3f}",
            "cpu_publish_s": f"{self._cpu['publish']:.3f}",
            "cpu_record_s": f"{self._cpu['record']:.3f}",
        }

    def _on_diagnostics(self) -> None:
        now = self._now_ns()
        values = self.diagnostics_values()
        if self.recording_error:
            level, message = DiagnosticStatus.ERROR, "recording failed"
        elif self.last_refusal or self.missed_deadlines:
            level, message = DiagnosticStatus.WARN, self.last_refusal or "missed deadlines"
        else:
            level, message = DiagnosticStatus.OK, f"mode {values['mode']}"
        msg = diagnostics_msg(now, self.get_name(), level, message, values)
        self.pub_diag.publish(msg)
        self._record(self.topic[self.pub_diag], msg, now)


def main(argv: list[str] | None = None) -> int:
    """Console script ``drs-node`` (``--ros-args -p name:=value`` as usual). Returns 0 on a clean
    SIGINT/SIGTERM, 2 when the parameters are refused."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    args = sys.argv if argv is None else argv
    rclpy.init(args=args)
    node = None
    rc = 0
    try:
        node = DRSNode()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (DRSError, ParameterException) as exc:
        print(f"drs-node: refused to start: {exc}", file=sys.stderr)
        rc = 2
    except Exception:
        if rclpy.ok():
            raise  # a real failure while running
        # SIGINT/SIGTERM shut the context down while a callback was running (rclpy then raises
        # e.g. RCLError "publisher's context is invalid" from inside the callback): that is the
        # requested stop, not a failure
    finally:
        if node is not None:
            node.close_recordings()
            node.destroy_node()
        rclpy.try_shutdown()
    return rc


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
