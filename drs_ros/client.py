"""A client of a running ``drs`` node over DDS: what a vehicle stack's software does to it.

:class:`DRSClient` is one rclpy node in its own context (a domain id of its own), listening to
the joint states, the gap and diagnostics, and sending the node's commands: the ``~/drs``
service, stroke, force and trajectory commands and FollowJointTrajectory goals. ``drs-demo``
drives the node with it. It spins its own executor; every wait has a timeout and raises
:class:`ClientError` with what did not arrive.
"""

from __future__ import annotations

import time

from .errors import DRSRosError
from .timestamps import ns_from_seconds, set_ns


class ClientError(DRSRosError, RuntimeError):
    """The node did not answer, or did not appear, within the client's timeout."""


class DRSClient:
    """A client of the node ``node_name`` (its fully qualified name, ``/drs`` by default).

    ``seen`` holds what the client observed: ``joint_states`` (count), ``gap_max`` [m],
    ``force_max`` (largest piston effort [N]) and ``diag`` (the last diagnostics' values).
    Use as a context manager, or call :meth:`close`."""

    def __init__(self, domain: int, node_name: str = "/drs", timeout: float = 30.0) -> None:
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
        self._ctx = Context()
        rclpy.init(context=self._ctx, domain_id=domain)
        self.node = Node("drs_client", context=self._ctx)
        self._ex = SingleThreadedExecutor(context=self._ctx)
        self._ex.add_node(self.node)
        self.seen: dict[str, object] = {"joint_states": 0, "gap_max": 0.0, "force_max": 0.0,
                                        "diag": None}  # fmt: skip
        sub = self.node.create_subscription
        sub(JointState, "/joint_states", self._on_joints, 100)
        sub(Float64, f"{node_name}/flap_gap", self._on_gap, 100)
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

    def _on_gap(self, msg) -> None:
        self.seen["gap_max"] = max(float(self.seen["gap_max"]), msg.data)

    def _on_diag(self, msg) -> None:
        self.seen["diag"] = {kv.key: kv.value for kv in msg.status[0].values}

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

    def _until(self, done, what: str) -> None:
        end = time.monotonic() + self.timeout
        while not done() and time.monotonic() < end:
            self._ex.spin_once(timeout_sec=0.01)
        if not done():
            raise ClientError(f"{what} within {self.timeout:g} s")

    def wait_ready(self, joint_states: int = 25) -> None:
        """Until the node's service answers, its command topics are matched and ``joint_states``
        joint states arrived (the service is discoverable before the node spins)."""
        if not self._service.wait_for_service(timeout_sec=self.timeout):
            raise ClientError(f"the node's ~/drs service did not appear within {self.timeout} s")
        self._until(lambda: self._stroke.get_subscription_count() > 0
                    and self._force.get_subscription_count() > 0,
                    "the node's command topics were not matched")  # fmt: skip
        self._until(lambda: int(self.seen["joint_states"]) >= joint_states,
                    "no /joint_states from the node")  # fmt: skip

    # ---- commands --------------------------------------------------------------------------------
    def call_drs(self, value: bool) -> str:
        """``~/drs`` with ``value`` (true opens); the answer in words."""
        fut = self._service.call_async(self._set_bool.Request(data=value))
        self._until(fut.done, "the ~/drs service did not answer")
        res = fut.result()
        return f"{'ok' if res.success else 'refused'}: {res.message}"

    def stroke(self, stroke: float) -> None:
        """``~/stroke_cmd``: move to ``stroke`` [m]."""
        self._stroke.publish(self._float(data=stroke))

    def force(self, force: float) -> None:
        """``~/force_cmd``: apply ``force`` [N]."""
        self._force.publish(self._float(data=force))

    def trajectory(self, points, joint: str = "drs_piston") -> None:
        """``~/trajectory_cmd``: reach each ``(time [s from now], stroke [m])`` of ``points``."""
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

        msg = JointTrajectory(joint_names=[joint])
        for t, s in points:
            point = JointTrajectoryPoint(positions=[s])
            set_ns(point.time_from_start, ns_from_seconds(t))
            msg.points.append(point)
        self._trajectory.publish(msg)

    def follow(self, stroke: float, seconds: float, joint: str = "drs_piston") -> str:
        """One FollowJointTrajectory goal, as a motion client sends it: reach ``stroke`` [m] in
        ``seconds`` [s]; its result in words."""
        from control_msgs.action import FollowJointTrajectory
        from rclpy.action import ActionClient
        from trajectory_msgs.msg import JointTrajectoryPoint

        client = ActionClient(self.node, FollowJointTrajectory,
                              f"{self.name}/follow_joint_trajectory")  # fmt: skip
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
        return (f"{stroke * 1e3:g} mm in {seconds * 1e3:g} ms (FollowJointTrajectory): "
                f"error_code {res.error_code}, {res.error_string!r}, {len(feedback)} feedback "
                "messages")  # fmt: skip

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


__all__ = ["ClientError", "DRSClient"]
