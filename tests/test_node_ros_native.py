"""The node the ROS way: ~/markers for RViz/Foxglove, lifecycle transitions over the standard
services, and parameter files (real DDS, loopback only)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from node_support import domain_for, node_env, spin_for, spin_until
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

require_rclpy()

from lifecycle_msgs.msg import State, Transition  # noqa: E402
from lifecycle_msgs.srv import ChangeState, GetState  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray  # noqa: E402

from drs_model import kinematics as kin  # noqa: E402
from drs_ros.node import DRSNode, ManagedDRSNode  # noqa: E402
from drs_ros.node.command_line import node_command  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / "config" / "drs.yaml"


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


def test_markers_draw_the_published_joint_state(ros_context, params):
    node = DRSNode(
        context=ros_context, parameter_overrides=[Parameter("markers_rate_hz", value=100.0)]
    )
    client = Node("viewer", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(client)
    joints: dict[int, JointState] = {}
    markers: list[MarkerArray] = []
    client.create_subscription(
        JointState, "/joint_states", lambda m: joints.__setitem__(_stamp(m), m), 1000
    )
    client.create_subscription(MarkerArray, "/drs/markers", markers.append, 100)
    stroke = client.create_publisher(Float64, "/drs/stroke_cmd", 10)
    try:
        assert spin_until(ex, lambda: len(markers) > 2, 10.0), "no markers"
        stroke.publish(Float64(data=0.03))
        n = len(markers)
        assert spin_until(ex, lambda: len(markers) > n + 5, 5.0)
        checked = 0
        for arr in markers:
            js = joints.get(_stamp(arr.markers[0]))
            if js is None:
                continue
            q = np.array([js.position])
            by_ns = {m.ns: m for m in arr.markers}
            pts = kin.point_positions(q, params)
            link = by_ns["drs/link"]
            assert link.header.frame_id == "drs_base" and link.type == Marker.LINE_STRIP
            got = np.array([[p.x, p.y] for p in link.points])
            np.testing.assert_allclose(got, np.vstack([pts["B"], pts["C"]]), atol=1e-9, rtol=0)
            piston = np.array([[p.x, p.y] for p in by_ns["drs/piston"].points])
            np.testing.assert_allclose(piston, np.vstack([pts["A"], pts["B"]]), atol=1e-9, rtol=0)
            flap = np.array([[p.x, p.y] for p in by_ns["drs/flap"].points])
            np.testing.assert_allclose(flap[:-1], kin.flap_outline(q, params)[0], atol=1e-9, rtol=0)
            arrow = by_ns["drs/force"]
            np.testing.assert_allclose(
                [arrow.points[0].x, arrow.points[0].y], pts["P"][0], atol=1e-9, rtol=0
            )
            # the arrow's length is the piston force, 1e-5 m/N
            assert arrow.points[1].y - arrow.points[0].y == pytest.approx(
                1e-5 * js.effort[0], abs=1e-12
            )
            assert all(abs(p.z) == 0.0 for m in arr.markers for p in m.points)
            checked += 1
        assert checked >= 5
        # the outlines that never move come once a second, and sit where the seed puts them
        wings = [m for arr in markers for m in arr.markers if m.ns == "drs/main_wing"]
        assert wings and 5 * len(wings) < len(markers)
        outline = np.array([[p.x, p.y] for p in wings[0].points])
        np.testing.assert_allclose(outline[:-1], kin.main_wing_outline(params), atol=1e-12, rtol=0)
    finally:
        ex.shutdown()
        client.destroy_node()
        node.destroy_node()


def test_markers_are_not_computed_for_nobody(ros_context):
    node = DRSNode(context=ros_context)  # no bag, no subscriber
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    try:
        spin_for(ex, 0.5)
        assert node.effects.ticks > 10 and node.outputs.last_markers_t is None
    finally:
        ex.shutdown()
        node.destroy_node()


class Lifecycle:
    """A second node driving the managed node over the standard lifecycle services."""

    def __init__(self, ctx, ex):
        self.node = Node("lifecycle_manager", context=ctx)
        ex.add_node(self.node)
        self.ex = ex
        self.change = self.node.create_client(ChangeState, "/drs/change_state")
        self.get = self.node.create_client(GetState, "/drs/get_state")
        assert self.change.wait_for_service(timeout_sec=5.0)

    def _call(self, client, request):
        fut = client.call_async(request)
        assert spin_until(self.ex, fut.done, 10.0)
        return fut.result()

    def state(self) -> int:
        return self._call(self.get, GetState.Request()).current_state.id

    def transition(self, transition_id: int) -> bool:
        req = ChangeState.Request()
        req.transition.id = transition_id
        return self._call(self.change, req).success


def test_every_lifecycle_transition_over_the_standard_services(ros_context, tmp_path):
    bag = tmp_path / "bag"
    node = ManagedDRSNode(
        context=ros_context, parameter_overrides=[Parameter("bag_path", value=str(bag))]
    )
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    manager = Lifecycle(ros_context, ex)
    joints: list = []
    manager.node.create_subscription(JointState, "/joint_states", joints.append, 100)
    try:
        assert manager.state() == State.PRIMARY_STATE_UNCONFIGURED
        spin_for(ex, 0.3)
        assert not joints and not bag.exists()  # nothing before configure
        assert manager.transition(Transition.TRANSITION_CONFIGURE)
        assert manager.state() == State.PRIMARY_STATE_INACTIVE
        assert (bag / "bag_0.mcap").exists()  # the recorders are open
        spin_for(ex, 0.3)
        assert not joints  # inactive: nothing published
        assert manager.transition(Transition.TRANSITION_ACTIVATE)
        assert manager.state() == State.PRIMARY_STATE_ACTIVE
        assert spin_until(ex, lambda: len(joints) > 10, 5.0)
        stroke = manager.node.create_publisher(Float64, "/drs/stroke_cmd", 10)
        assert spin_until(ex, lambda: stroke.get_subscription_count() > 0, 5.0)
        stroke.publish(Float64(data=0.03))
        assert spin_until(ex, lambda: abs(joints[-1].position[0] - 0.03) < 1e-12, 5.0)
        assert manager.transition(Transition.TRANSITION_DEACTIVATE)
        assert manager.state() == State.PRIMARY_STATE_INACTIVE
        spin_for(ex, 0.1)
        n = len(joints)
        spin_for(ex, 0.4)
        assert len(joints) == n  # deactivated: holds, publishes nothing
        assert manager.transition(Transition.TRANSITION_ACTIVATE)
        assert spin_until(ex, lambda: len(joints) > n + 5, 5.0)
        assert joints[-1].position[0] == pytest.approx(0.03, abs=1e-12)  # it held its state
        assert manager.transition(Transition.TRANSITION_DEACTIVATE)
        assert manager.transition(Transition.TRANSITION_CLEANUP)
        assert manager.state() == State.PRIMARY_STATE_UNCONFIGURED
        # the recording is complete after cleanup: every byte verified, the model checks pass
        res = subprocess.run(
            [sys.executable, "-m", "drs_ros.bag.cli", "check", str(bag)],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert res.returncode == 0, res.stdout[-2000:] + res.stderr
        assert manager.transition(Transition.TRANSITION_UNCONFIGURED_SHUTDOWN)
        assert manager.state() == State.PRIMARY_STATE_FINALIZED
    finally:
        ex.shutdown()
        manager.node.destroy_node()
        node.destroy_node()


def test_a_failing_configure_is_reported_and_leaves_nothing(ros_context, tmp_path):
    rrd = tmp_path / "run.rrd"
    rrd.write_bytes(b"an earlier recording")
    node = ManagedDRSNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("bag_path", value=str(tmp_path / "bag")),
            Parameter("rrd_path", value=str(rrd)),
        ],
    )
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    manager = Lifecycle(ros_context, ex)
    try:
        assert not manager.transition(Transition.TRANSITION_CONFIGURE)
        assert manager.state() == State.PRIMARY_STATE_UNCONFIGURED
        assert not (tmp_path / "bag").exists() and rrd.read_bytes() == b"an earlier recording"
    finally:
        ex.shutdown()
        manager.node.destroy_node()
        node.destroy_node()


def test_the_parameter_file_holds_every_parameter_at_its_default(ros_context):
    """config/drs.yaml holds every node parameter at its default but the model's: those it
    leaves to model_params_file (it would shadow the file), and the node serves them at the
    seed's and HydraulicParams' values."""
    from drs_model.fidelity import HydraulicParams
    from drs_model.params import DRSParams
    from drs_ros.node.parameters import MODEL_PARAMETERS

    values = yaml.safe_load(CONFIG.read_text())["/drs"]["ros__parameters"]
    assert "model" not in values and "hydraulic" not in values
    flat = {k: v for k, v in values.items() if k != "fault"}
    for k, v in values["fault"].items():  # fault.sensor.* nest one level deeper
        subs = v.items() if isinstance(v, dict) else [(None, v)]
        flat.update({f"fault.{k}" + ("" if s is None else f".{s}"): x for s, x in subs})
    node = DRSNode(context=ros_context)
    try:
        rclpy_own = {"use_sim_time", "start_type_description_service"}  # declared by rclpy
        declared = {n for n in node.get_parameters_by_prefix("") if n not in rclpy_own}
        assert set(flat) | set(MODEL_PARAMETERS) == declared
        for name, value in flat.items():
            have = node.get_parameter(name).value
            assert (list(have) if isinstance(have, (list, tuple)) else have) == value, name
        seed, hp = DRSParams(), HydraulicParams()
        for name in MODEL_PARAMETERS:
            owner, field = name.split(".", 1)
            want = getattr(seed if owner == "model" else hp, field)
            want = hp.port_ratio if field == "valve_port_ratio" else want
            assert node.get_parameter(name).value == want, name
    finally:
        node.destroy_node()
    text = CONFIG.read_text().splitlines()
    for i, line in enumerate(text):  # a comment above every parameter
        if (
            line.startswith("    ")
            and ":" in line
            and not line.strip().startswith("#")
            and line.strip() not in ("model:", "ros__parameters:")
        ):
            assert text[i - 1].strip().startswith("#"), line


def _run_node(tmp_path, request, *ros_args, seconds=3.0):
    proc = subprocess.Popen(
        node_command(ros_args=ros_args),
        env=node_env(tmp_path, domain_for(request.node.nodeid)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        rc = proc.wait(timeout=seconds)  # a refusal ends it at once
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
        rc = None
    out, err = proc.communicate(timeout=30)
    return rc, proc.returncode, out, err


def test_the_parameter_file_round_trip(tmp_path, request):
    """Start from config/drs.yaml with two values changed: the node runs with exactly the
    file's values (read back from the parameters it records in its bag)."""
    from decoded_support import read_bag

    from drs_ros.bag.read.effects import recorded_node_parameters

    values = yaml.safe_load(CONFIG.read_text())
    params = values["/drs"]["ros__parameters"]
    params["publish_rate_hz"] = 125  # an integer for a double, as a person would write it
    params["model"] = {"m_wing": 2.5}  # the shipped file sets no model.* value
    params["bag_path"] = str(tmp_path / "bag")
    path = tmp_path / "drs.yaml"
    path.write_text(yaml.safe_dump(values))
    rc, final, _out, err = _run_node(tmp_path, request, "--params-file", str(path), seconds=6.0)
    assert rc is None and final == 0, err[-2000:]
    data = read_bag(tmp_path / "bag", ["/parameter_events"])
    recorded = recorded_node_parameters(data.messages["/parameter_events"])
    assert recorded["publish_rate_hz"] == 125.0 and recorded["model.m_wing"] == 2.5
    assert recorded["model.Iz_wing"] == pytest.approx(2.5 * 0.12**2 / 3, rel=1e-15)  # derived
    for name, value in params.pop("fault").items():  # healthy, as the file gives them
        for sub, v in value.items() if isinstance(value, dict) else [(None, value)]:
            key = f"fault.{name}" if sub is None else f"fault.{name}.{sub}"
            assert recorded[key] == v, key
    for name, value in params.items():
        if name != "model":
            have = recorded[name]
            assert (list(have) if isinstance(have, (list, tuple)) else have) == value, name


def test_a_bad_value_in_the_parameter_file_is_refused_like_on_the_command_line(tmp_path, request):
    values = yaml.safe_load(CONFIG.read_text())
    values["/drs"]["ros__parameters"]["publish_rate_hz"] = 1.0e6
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(values))
    # a refusal ends the node as soon as it has read its parameters; on a loaded machine the
    # start-up alone (rclpy, numba's cache) can take seconds, so wait long for the exit
    rc_file, _, _, err_file = _run_node(tmp_path, request, "--params-file", str(path), seconds=60.0)
    rc_cli, _, _, err_cli = _run_node(
        tmp_path, request, "-p", "publish_rate_hz:=1000000.0", seconds=60.0
    )
    assert rc_file == rc_cli == 2
    line_file = [ln for ln in err_file.splitlines() if "refused to start" in ln]
    line_cli = [ln for ln in err_cli.splitlines() if "refused to start" in ln]
    assert line_file == line_cli and len(line_file) == 1
    assert "publish_rate_hz" in line_file[0]
    time.sleep(0)


def test_rerun_connect_refuses_a_host_off_loopback(ros_context, tmp_path):
    """A live rerun stream goes to loopback only; a bad URL refuses to start, leaving nothing."""
    from drs_ros.recording.rerun_recorder import RerunLogError

    for url, reason in (("rerun+http://192.0.2.7:9876/proxy", "loopback"), ("not a url", "rerun")):
        with pytest.raises(RerunLogError, match=reason):
            DRSNode(
                context=ros_context,
                parameter_overrides=[
                    Parameter("rerun_connect", value=url),
                    Parameter("bag_path", value=str(tmp_path / "bag")),
                ],
            )
        assert not (tmp_path / "bag").exists()
