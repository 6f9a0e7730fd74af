"""A client of a running ``drs`` node over DDS: what a vehicle stack's software does to it.

:class:`DRSClient` is one rclpy node in its own context (a domain id of its own), listening to
the joint states, the gap and diagnostics, and sending the node's commands: the ``~/drs``
service, stroke, force and trajectory commands, FollowJointTrajectory goals and parameter
changes. ``drs-demo``, the tests of the node as a process and the node's benchmarks drive it with
it. It spins its own executor; every wait has a timeout and raises :class:`ClientError` with
what did not arrive (:meth:`DRSClient.wait_for` only says whether it did).
"""

from __future__ import annotations

import math
import time

from .dds_profile import use_discovery_profile
from .errors import DRSRosError
from .timestamps import ns_from_seconds, set_ns


class ClientError(DRSRosError, RuntimeError):
    """The node did not answer, or did not appear, within the client's timeout."""


#: How long [s] :meth:`DRSClient.call_drs` waits for an answer before it sends the call again.
RESEND_S = 2.0

#: What a client can listen to: the node's joint states, its gap and the diagnostics.
LISTENS = ("joint_states", "flap_gap", "diagnostics")


class DRSClient:
    """A client of the node ``node_name`` (its fully qualified name, ``/drs`` by default).

    ``seen`` holds what the client observed: ``joint_states`` (count), ``gap_max`` [m],
    ``force_max`` (largest piston effort [N]) and ``diag`` (the last diagnostics' values).
    With ``keep`` it also keeps every message: ``joint_state_msgs`` (each JointState, in
    order), ``arrival_times`` (when each arrived, ``time.monotonic()`` [s]) and
    ``diagnostic_statuses`` (each DiagnosticStatus). ``listen`` names what it subscribes to
    (of :data:`LISTENS`; default all, none for a command stream alone). ``client_name`` names
    the client's own node. Use as a context manager, or call :meth:`close`."""

    def __init__(
        self,
        domain: int,
        node_name: str = "/drs",
        timeout: float = 30.0,
        *,
        keep: bool = False,
        listen=LISTENS,
        client_name: str = "drs_client",
    ) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64
        from std_srvs.srv import SetBool
        from trajectory_msgs.msg import JointTrajectory

        self.timeout, self.name = timeout, node_name
        use_discovery_profile()  # a node started after this client is found within 0.5 s
        self._ctx = Context()
        rclpy.init(context=self._ctx, domain_id=domain)
        self.node = Node(client_name, context=self._ctx)
        self._ex = SingleThreadedExecutor(context=self._ctx)
        self._ex.add_node(self.node)
        self.seen: dict[str, object] = {
            "joint_states": 0,
            "gap_max": 0.0,
            "force_max": 0.0,
            "diag": None,
        }
        self.keep = keep
        self.joint_state_msgs: list = []
        self.arrival_times: list[float] = []
        self.diagnostic_statuses: list = []
        self._parameters = None  # the node's parameter client, made at the first change
        unknown = set(listen) - set(LISTENS)
        if unknown:
            raise ClientError(f"listen must name some of {LISTENS}, got {sorted(unknown)}")
        sub = self.node.create_subscription
        if "joint_states" in listen:
            sub(JointState, "/joint_states", self._on_joints, 100)
        if "flap_gap" in listen:
            sub(Float64, f"{node_name}/flap_gap", self._on_gap, 100)
        if "diagnostics" in listen:
            sub(DiagnosticArray, "/diagnostics", self._on_diag, 10)
        pub = self.node.create_publisher
        self._stroke = pub(Float64, f"{node_name}/stroke_cmd", 10)
        self._force = pub(Float64, f"{node_name}/force_cmd", 10)
        self._trajectory = pub(JointTrajectory, f"{node_name}/trajectory_cmd", 10)
        self._service = self.node.create_client(SetBool, f"{node_name}/drs")
        self._float, self._set_bool = Float64, SetBool

    # ---- what arrives ----------------------------------------------------------------------------
    def _on_joints(self, msg) -> None:
        self.seen["joint_states"] = int(self.seen["joint_states"]) + 1
        self.seen["force_max"] = max(float(self.seen["force_max"]), abs(msg.effort[0]))
        if self.keep:
            self.arrival_times.append(time.monotonic())
            self.joint_state_msgs.append(msg)

    def _on_gap(self, msg) -> None:
        self.seen["gap_max"] = max(float(self.seen["gap_max"]), msg.data)

    def _on_diag(self, msg) -> None:
        self.seen["diag"] = {kv.key: kv.value for kv in msg.status[0].values}
        if self.keep:
            self.diagnostic_statuses.extend(msg.status)

    def stroke_now(self) -> float:
        """The stroke [m] of the last joint state kept (NaN before the first, or without
        ``keep``)."""
        return self.joint_state_msgs[-1].position[0] if self.joint_state_msgs else math.nan

    def listen(self, msg_type, topic: str) -> None:
        """Subscribe to ``topic`` without keeping its messages (the node computes some topics,
        e.g. its reactions, only while someone listens)."""
        self.node.create_subscription(msg_type, topic, lambda _m: None, 100)

    # ---- waiting ---------------------------------------------------------------------------------
    def spin(self, seconds: float) -> None:
        """Take what arrives for ``seconds`` [s]."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self._ex.spin_once(timeout_sec=0.002)

    def wait_for(self, done, timeout: float | None = None) -> bool:
        """Take what arrives until ``done()`` or ``timeout`` [s] (default: the client's);
        whether ``done()`` came true."""
        end = time.monotonic() + (self.timeout if timeout is None else timeout)
        while not done() and time.monotonic() < end:
            self._ex.spin_once(timeout_sec=0.01)
        return bool(done())

    def _until(self, done, what: str) -> None:
        if not self.wait_for(done):
            raise ClientError(f"{what} within {self.timeout:g} s")

    def commands_matched(self) -> bool:
        """Whether the node subscribes to the stroke, force and trajectory commands."""
        pubs = (self._stroke, self._force, self._trajectory)
        return all(pub.get_subscription_count() > 0 for pub in pubs)

    def wait_ready(self, joint_states: int = 25) -> None:
        """Until the node's service answers, its command topics are matched and ``joint_states``
        joint states arrived (the service is discoverable before the node spins)."""
        if not self._service.wait_for_service(timeout_sec=self.timeout):
            raise ClientError(f"the node's ~/drs service did not appear within {self.timeout} s")
        self._until(self.commands_matched, "the node's command topics were not matched")
        self._until(
            lambda: int(self.seen["joint_states"]) >= joint_states, "no /joint_states from the node"
        )

    # ---- commands --------------------------------------------------------------------------------
    def request_drs(self, value: bool):
        """``~/drs`` with ``value`` (true opens), not waiting for the answer: its future."""
        if not self._service.service_is_ready() and not self._service.wait_for_service(
            timeout_sec=self.timeout
        ):
            raise ClientError(f"the node's ~/drs service did not appear within {self.timeout} s")
        return self._service.call_async(self._set_bool.Request(data=value))

    def call_drs(self, value: bool) -> str:
        """``~/drs`` with ``value`` (true opens); the answer in words. A call unanswered for
        :data:`RESEND_S` is sent again (its first future dropped), until the client's timeout:
        a node that received the request before it had discovered this client's reply reader
        answers into the void (a ROS 2 service is two topics discovered apart; rcl#1048), and
        the client would wait for nothing (one fresh-clone suite run in five, the first call
        after a node started). Opening or closing twice is the same request."""
        end = time.monotonic() + self.timeout
        fut = self.request_drs(value)
        while not self.wait_for(fut.done, min(RESEND_S, max(end - time.monotonic(), 0.0))):
            if time.monotonic() >= end:
                raise ClientError(f"the ~/drs service did not answer within {self.timeout:g} s")
            self._service.remove_pending_request(fut)
            fut = self.request_drs(value)
        res = fut.result()
        return f"{'ok' if res.success else 'refused'}: {res.message}"

    def stroke(self, stroke: float) -> None:
        """``~/stroke_cmd``: move to ``stroke`` [m]."""
        self._stroke.publish(self._float(data=stroke))

    def force(self, force: float) -> None:
        """``~/force_cmd``: apply ``force`` [N]."""
        self._force.publish(self._float(data=force))

    def trajectory(self, points, joint: str = "drs_piston") -> None:
        """``~/trajectory_cmd``: reach each ``(time [s from now], stroke [m])`` of ``points``,
        or send ``points`` as it is when it is a JointTrajectory message."""
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

        if isinstance(points, JointTrajectory):
            self._trajectory.publish(points)
            return
        msg = JointTrajectory(joint_names=[joint])
        for t, s in points:
            point = JointTrajectoryPoint(positions=[s])
            set_ns(point.time_from_start, ns_from_seconds(t))
            msg.points.append(point)
        self._trajectory.publish(msg)

    def set_parameter(self, name: str, value):
        """Set the node's parameter ``name`` to ``value`` (a ``fault.*`` one, say) through its
        parameter service: the node's SetParametersResult (``successful``, ``reason``)."""
        from rclpy.parameter import Parameter
        from rclpy.parameter_client import AsyncParameterClient

        if self._parameters is None:
            self._parameters = AsyncParameterClient(self.node, self.name)
            if not self._parameters.wait_for_services(self.timeout):
                raise ClientError(
                    f"the node's parameter services did not appear within {self.timeout:g} s"
                )
        fut = self._parameters.set_parameters([Parameter(name, value=value)])
        self._until(fut.done, f"no answer setting {name}")
        return fut.result().results[0]

    def follow(self, stroke: float, seconds: float, joint: str = "drs_piston") -> str:
        """One FollowJointTrajectory goal, as a motion client sends it: reach ``stroke`` [m] in
        ``seconds`` [s]; its result in words."""
        from control_msgs.action import FollowJointTrajectory
        from rclpy.action import ActionClient
        from trajectory_msgs.msg import JointTrajectoryPoint

        client = ActionClient(
            self.node, FollowJointTrajectory, f"{self.name}/follow_joint_trajectory"
        )
        try:
            if not client.wait_for_server(timeout_sec=self.timeout):
                raise ClientError("the node's ~/follow_joint_trajectory did not appear")
            goal = FollowJointTrajectory.Goal()
            goal.trajectory.joint_names = [joint]
            point = JointTrajectoryPoint(positions=[stroke])
            set_ns(point.time_from_start, ns_from_seconds(seconds))  # nanosec < 1e9, any seconds
            goal.trajectory.points = [point]
            feedback: list = []
            sent = client.send_goal_async(goal, feedback_callback=feedback.append)
            self._until(sent.done, "the FollowJointTrajectory goal was not answered")
            result = sent.result().get_result_async()
            self._until(result.done, "no FollowJointTrajectory result")
            res = result.result().result
        finally:
            client.destroy()
        return (
            f"{stroke * 1e3:g} mm in {seconds * 1e3:g} ms (FollowJointTrajectory): "
            f"error_code {res.error_code}, {res.error_string!r}, {len(feedback)} feedback "
            "messages"
        )

    # ---- life ------------------------------------------------------------------------------------
    def close(self) -> None:
        import rclpy

        self._ex.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self._ctx)

    def __enter__(self) -> DRSClient:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = ["LISTENS", "ClientError", "DRSClient"]
