"""The drs node over real DDS (loopback only): topics, service, commands, parameters, sim time."""

from __future__ import annotations

import math

import numpy as np
import pytest
from node_support import NodeAndClient, spin_for, spin_until
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

require_rclpy()  # skip/fail the whole module at collection without rclpy (see ros_support)

from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402

from drs_model import kinematics as kin  # noqa: E402
from drs_model.constraints import constraint  # noqa: E402
from drs_model.inverse import inverse_dynamics  # noqa: E402
from drs_ros.node import DRSNode  # noqa: E402


class Harness(NodeAndClient):
    """The node and a client node of its own topics and service, in one context and executor."""

    def __init__(self, ctx, overrides=()):
        super().__init__(ctx, overrides, "drs_test_client")
        self.joints: list[JointState] = []
        self.forces: list[float] = []
        self.gaps: list[float] = []
        self.reactions: list[JointState] = []
        c = self.client
        c.create_subscription(JointState, "/joint_states", self.joints.append, 100)
        c.create_subscription(
            Float64, "/drs/piston_force", lambda m: self.forces.append(m.data), 100
        )
        c.create_subscription(Float64, "/drs/flap_gap", lambda m: self.gaps.append(m.data), 100)
        self.stroke_pub = c.create_publisher(Float64, "/drs/stroke_cmd", 1000)
        self.force_pub = c.create_publisher(Float64, "/drs/force_cmd", 1000)
        self.drs = c.create_client(SetBool, "/drs/drs")

    def wait_connected(self):
        assert spin_until(self.exec, lambda: len(self.joints) > 3, 10.0), "no /joint_states"
        assert spin_until(
            self.exec,
            lambda: (
                self.node.sub_stroke.get_publisher_count() > 0
                and self.node.sub_force.get_publisher_count() > 0
            ),
            5.0,
        )
        assert self.drs.wait_for_service(timeout_sec=5.0)

    def call_drs(self, value: bool):
        fut = self.drs.call_async(SetBool.Request(data=value))
        assert spin_until(self.exec, fut.done, 5.0)
        return fut.result()


@pytest.fixture
def harness(ros_context, tmp_path):
    h = Harness(ros_context, [Parameter("bag_path", value=str(tmp_path / "bag"))])
    yield h
    h.close()


def test_joint_states_are_consistent_and_stamped(harness, params):
    harness.wait_connected()
    msg = harness.joints[-1]
    assert list(msg.name) == ["drs_piston", "drs_link", "drs_flap"]
    assert len(msg.position) == len(msg.velocity) == len(msg.effort) == 3
    q = np.array(msg.position)
    assert np.abs(constraint(q, params)).max() < 1e-12
    assert q[0] == pytest.approx(kin.stroke_limits(params)[0], abs=1e-12)  # starts closed
    assert math.isnan(msg.effort[1]) and math.isnan(msg.effort[2])
    # the static force to hold the closed flap, by an independent formulation (Lagrange)
    st = kin.kinematic_state(np.array([q[0]]), np.zeros(1), np.zeros(1), params)
    expected = float(inverse_dynamics(st, params, method="lagrange").piston_force[0])
    assert msg.effort[0] == pytest.approx(expected, rel=1e-9)
    assert harness.forces[-1] == pytest.approx(expected, rel=1e-9)
    assert harness.gaps[-1] == pytest.approx(0.010, abs=1e-12)
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in harness.joints]
    assert all(b > a for a, b in zip(stamps, stamps[1:], strict=False))
    now = harness.node.get_clock().now().nanoseconds
    assert abs(now - stamps[-1]) < 0.5e9


def test_service_opens_and_closes_with_the_seed_times(harness, params):
    harness.wait_connected()
    res = harness.call_drs(True)
    assert res.success and "opening" in res.message
    assert spin_until(harness.exec, lambda: abs(harness.gaps[-1] - 0.05) < 1e-9, 3.0)
    s_min, s_max = kin.stroke_limits(params)
    assert harness.joints[-1].position[0] == pytest.approx(s_max, abs=1e-12)
    # the opening took T_opening of simulated time (stamps = t0 + simulated time): the last
    # closed sample and the first open one bracket it within a publish period
    st = [
        (m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, m.position[0]) for m in harness.joints
    ]
    last_closed = max(t for t, s in st if s <= s_min + 1e-12)
    first_open = min(t for t, s in st if s >= s_max - 1e-12)
    # never faster than T_opening; slower only by the sampling (a late tick on a loaded machine
    # publishes several steps at once: allow the largest gap between published states)
    gap = max(b[0] - a[0] for a, b in zip(st, st[1:], strict=False))
    assert params.T_opening - 1e-6 <= first_open - last_closed <= params.T_opening + 2 * gap
    res = harness.call_drs(False)
    assert res.success and "closing" in res.message
    assert spin_until(harness.exec, lambda: abs(harness.gaps[-1] - 0.01) < 1e-9, 3.0)


def test_stroke_command_moves_smoothly_and_reactions_on_demand(harness, params):
    harness.wait_connected()
    harness.stroke_pub.publish(Float64(data=0.02))
    assert spin_until(harness.exec, lambda: abs(harness.joints[-1].position[0] - 0.02) < 1e-12, 3.0)
    s = np.array([m.position[0] for m in harness.joints])
    assert np.all(np.diff(s) >= -1e-15)  # monotonic move, no overshoot
    assert s.max() <= 0.02 + 1e-12
    # reactions are published only while somebody listens
    assert harness.node.outputs.reactions.get_subscription_count() == 0
    got = []
    harness.client.create_subscription(JointState, "/drs/joint_reactions", got.append, 10)
    assert spin_until(harness.exec, lambda: len(got) > 2, 5.0)
    r = dict(zip(got[-1].name, got[-1].effort, strict=True))
    # at rest the prismatic joint carries rj1y = m_pist g - F (seed's sign convention)
    f = harness.forces[-1]
    assert r["rj1y"] == pytest.approx(params.m_pist * params.g - f, rel=1e-9, abs=1e-9)


def test_bad_commands_are_refused_and_the_node_keeps_running(harness, params):
    harness.wait_connected()
    # one at a time, each after the last was refused: each is refused once, for its own reason
    # (a newer command of its topic before the next physics step would supersede it instead)
    for pub, key, bad in [
        (harness.stroke_pub, "stroke_cmd", v) for v in (math.nan, math.inf, 0.1, -0.01)
    ] + [
        (harness.force_pub, "force_cmd", math.nan),
        (harness.force_pub, "force_cmd", 1e9),
    ]:
        refused = harness.node.effects.refused
        pub.publish(Float64(data=bad))
        assert spin_until(harness.exec, lambda r=refused: harness.node.effects.refused > r, 5.0)
        assert harness.node.effects.refused == refused + 1
        assert harness.node.effects.last_refusal.startswith(f"{key} {bad!r} refused: ")
    ticks = harness.node.effects.ticks
    spin_for(harness.exec, 0.3)
    assert harness.node.effects.ticks > ticks  # still running at its rate
    assert harness.joints[-1].position[0] == pytest.approx(kin.stroke_limits(params)[0], abs=1e-12)
    assert "refused" in harness.node.effects.last_refusal
    reasons = harness.node.effects.refusals
    assert any("stroke command must be finite, got nan" in r for r in reasons)
    assert any("target stroke 0.1 m is outside [s_min, s_max]" in r for r in reasons)
    assert any("force command 1000000000.0 N is outside [-30000, 30000] N" in r for r in reasons)
    assert harness.node.effects.superseded == 0
    values = harness.node.diagnostics_values()
    assert int(values["refused_commands"]) >= 6


def test_force_command_drives_the_flap_to_the_open_stop(harness, params):
    harness.wait_connected()
    harness.force_pub.publish(Float64(data=3000.0))
    s_max = kin.stroke_limits(params)[1]
    assert spin_until(
        harness.exec, lambda: abs(harness.joints[-1].position[0] - s_max) < 1e-12, 3.0
    )
    assert harness.node.sim.state.at_stop == "open"
    assert spin_until(harness.exec, lambda: harness.forces[-1] == 3000.0, 2.0)
    # a force below the air load lets it fall back onto the closed stop
    harness.force_pub.publish(Float64(data=0.0))
    s_min = kin.stroke_limits(params)[0]
    assert spin_until(
        harness.exec, lambda: abs(harness.joints[-1].position[0] - s_min) < 1e-12, 3.0
    )
    assert harness.node.sim.state.at_stop == "closed"
    q = np.array(harness.joints[-1].position)
    assert np.abs(constraint(q, params)).max() < 1e-10


def test_parameters_are_declared_with_ranges(ros_context):
    from rclpy.exceptions import InvalidParameterValueException

    with pytest.raises(InvalidParameterValueException, match=r"physics_rate_hz"):
        DRSNode(context=ros_context, parameter_overrides=[Parameter("physics_rate_hz", value=1e6)])
    node = DRSNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("physics_rate_hz", value=2000.0),
            Parameter("model.m_wing", value=3.0),
        ],
    )
    try:
        assert node.physics_dt == pytest.approx(5e-4)
        assert node.params.m_wing == 3.0
        desc = node.describe_parameter("publish_rate_hz")
        assert desc.description and desc.read_only
        res = node.set_parameters([Parameter("publish_rate_hz", value=100.0)])
        assert not res[0].successful and "read-only" in res[0].reason
    finally:
        node.destroy_node()


def test_bad_model_parameter_is_refused_with_a_reason(ros_context):
    """A refusal to start (drs_ros's StartupError) naming the node parameter, with the model's
    reason (its ParameterError, the cause)."""
    from drs_model.errors import ParameterError
    from drs_ros.node.parameters import StartupError

    with pytest.raises(StartupError, match=r"model\.L2:=-1\.0: L2 must be > 0 m") as exc:
        DRSNode(context=ros_context, parameter_overrides=[Parameter("model.L2", value=-1.0)])
    assert isinstance(exc.value.__cause__, ParameterError)


def test_use_sim_time_follows_clock(ros_context):
    from builtin_interfaces.msg import Time
    from rclpy.node import Node
    from rosgraph_msgs.msg import Clock

    node = DRSNode(context=ros_context, parameter_overrides=[Parameter("use_sim_time", value=True)])
    client = Node("clock_pub", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(client)
    joints = []
    client.create_subscription(JointState, "/joint_states", joints.append, 100)
    clock_pub = client.create_publisher(Clock, "/clock", 10)
    try:
        t_ns = 100 * 10**9
        for _ in range(300):
            t_ns += 4_000_000  # 4 ms of simulated time per message
            clock_pub.publish(Clock(clock=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9)))
            spin_for(ex, 0.003)
            if len(joints) > 20:
                break
        assert len(joints) > 20
        stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in joints])
        assert stamps.min() >= 100.0 and stamps.max() <= t_ns * 1e-9 + 1e-9
        # the simulation advanced by simulated time (the /clock span), not by wall time
        span = (t_ns - 100 * 10**9) * 1e-9
        assert node.sim.t <= span + 1e-9
        assert node.sim.t >= 0.5 * span
    finally:
        ex.shutdown()
        client.destroy_node()
        node.destroy_node()


def test_a_40_hz_clock_gives_no_missed_deadline(ros_context):
    """``ros2 bag play --clock`` publishes /clock at 40 Hz: the node ticks once per message, 25 ms
    of node time apart against a 4 ms publish period. A coarse clock is no missed deadline, and
    the simulation still follows it step for step (no step dropped)."""
    from builtin_interfaces.msg import Time
    from rclpy.node import Node
    from rosgraph_msgs.msg import Clock

    node = DRSNode(context=ros_context, parameter_overrides=[Parameter("use_sim_time", value=True)])
    client = Node("clock_pub", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(client)
    clock_pub = client.create_publisher(Clock, "/clock", 10)
    try:
        t_ns = 100 * 10**9
        for _ in range(40):
            t_ns += 25_000_000
            clock_pub.publish(Clock(clock=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9)))
            spin_for(ex, 0.025)
        assert node.effects.ticks > 20  # the node followed the clock
        assert node.sim.t > 0.5
        assert node.effects.missed_deadlines == 0
        assert node.effects.dropped_steps == 0
        assert "missed_deadline" not in node.effects.troubles.recent(t_ns)
    finally:
        ex.shutdown()
        client.destroy_node()
        node.destroy_node()


def test_an_existing_recording_is_never_overwritten(ros_context, tmp_path):
    from drs_ros.recording.errors import RecordingError

    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "bag_0.mcap").write_bytes(b"an earlier run")
    with pytest.raises(RecordingError, match=r"already holds files"):
        DRSNode(context=ros_context, parameter_overrides=[Parameter("bag_path", value=str(bag))])
    assert (bag / "bag_0.mcap").read_bytes() == b"an earlier run"


def test_a_failing_recorder_stops_recording_not_the_actuator(ros_context, tmp_path, params):
    from rclpy.executors import SingleThreadedExecutor as Exec

    node = DRSNode(
        context=ros_context, parameter_overrides=[Parameter("bag_path", value=str(tmp_path / "b"))]
    )
    ex = Exec(context=ros_context)
    ex.add_node(node)

    def disk_full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    try:
        spin_until(ex, lambda: node.effects.ticks > 5, 5.0)
        # every write of the bag fails: the tick's batch (states, /tf) and single records
        node.recordings.recorder.write = disk_full
        node.recordings.recorder.write_many = disk_full
        node.sim.command_drs(True)
        ticks = node.effects.ticks
        spin_until(ex, lambda: node.effects.ticks > ticks + 10, 5.0)
        assert "No space left on device" in node.recordings.bag.health.failure
        assert node.diagnostics_values()["bag"].startswith("failed: OSError")
        assert node.effects.ticks > ticks + 10  # the actuator kept running
        assert node.sim.state.gap == pytest.approx(0.05, abs=1e-9)  # and opened
    finally:
        ex.shutdown()
        node.close_recordings()
        node.destroy_node()


def test_joint_names_must_name_three_joints(ros_context):
    from rclpy.exceptions import ParameterException

    with pytest.raises(ParameterException, match=r"joint_names must hold 3 names"):
        DRSNode(
            context=ros_context, parameter_overrides=[Parameter("joint_names", value=["a", "b"])]
        )


def test_trajectory_command_over_dds(harness, params):
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    harness.wait_connected()
    pub = harness.client.create_publisher(JointTrajectory, "/drs/trajectory_cmd", 10)
    assert spin_until(harness.exec, lambda: harness.node.sub_trajectory.get_publisher_count() > 0)

    def traj(joint, points):
        msg = JointTrajectory(joint_names=[joint, "drs_flap"])
        for t, s in points:
            msg.points.append(
                JointTrajectoryPoint(
                    positions=[s, 0.0],
                    velocities=[0.0, 0.0],  # at rest at each point: the held top is flat
                    time_from_start=Duration(sec=0, nanosec=int(t * 1e9)),
                )
            )
        return msg

    # the top is held for 0.3 s: a tick stalled by a loaded machine catches the simulation up
    # and publishes only its last state, so a peak passed at a point would be missed by the
    # published samples (one run saw 0.0196 m); a held top is sampled by some tick
    pub.publish(traj("drs_piston", [(0.2, 0.03), (0.5, 0.03), (0.7, 0.01)]))
    assert spin_until(harness.exec, lambda: harness.node.effects.accepted >= 1, 3.0)
    assert spin_until(harness.exec, lambda: abs(harness.joints[-1].position[0] - 0.01) < 1e-12, 3.0)
    assert max(m.position[0] for m in harness.joints) == pytest.approx(0.03, abs=2e-3)
    # a trajectory for another joint, or past the stroke range, is refused with the reason
    pub.publish(traj("elsewhere", [(0.02, 0.03)]))
    assert spin_until(harness.exec, lambda: harness.node.effects.refused >= 1, 3.0)
    pub.publish(traj("drs_piston", [(0.02, 0.3)]))
    assert spin_until(harness.exec, lambda: harness.node.effects.refused >= 2, 3.0)
    reasons = list(harness.node.effects.refusals)
    assert any("trajectory must name joint 'drs_piston'" in r for r in reasons)
    assert any("stroke 0.3 m is outside [s_min, s_max]" in r for r in reasons)


def _trajectory(names, points):
    """JointTrajectory from ``(t [s], positions, velocities)`` tuples."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    msg = JointTrajectory(joint_names=list(names))
    for t, pos, vel in points:
        msg.points.append(
            JointTrajectoryPoint(
                positions=list(pos),
                velocities=list(vel),
                time_from_start=Duration(sec=int(t), nanosec=int(round((t % 1) * 1e9))),
            )
        )
    return msg


@pytest.mark.parametrize(
    ("names", "points", "reason"),
    [
        (["drs_piston"], [(0.02, [0.03], [0.0, 1.0])], "has 2 velocities for 1 joint_names"),
        (["drs_piston", "drs_flap"], [(0.02, [0.03], [])], "has 1 positions for 2 joint_names"),
        (["drs_piston"], [(0.02, [0.03], []), (0.02, [0.01], [])], "must increase strictly"),
        (["drs_piston", "drs_piston"], [(0.02, [0.03, 0.03], [])], "must be unique"),
        (["drs_piston"], [(0.02, [0.03], [0.5])], "must end at rest"),
    ],
)
def test_trajectory_validation_refuses_with_a_reason(harness, names, points, reason):
    from trajectory_msgs.msg import JointTrajectory

    harness.wait_connected()
    pub = harness.client.create_publisher(JointTrajectory, "/drs/trajectory_cmd", 10)
    assert spin_until(harness.exec, lambda: harness.node.sub_trajectory.get_publisher_count() > 0)
    pub.publish(_trajectory(names, points))
    assert spin_until(harness.exec, lambda: harness.node.effects.refused >= 1, 3.0)
    assert harness.node.effects.accepted == 0
    assert reason in harness.node.effects.last_refusal


def test_a_trajectory_ends_at_rest_and_the_state_is_what_the_physics_holds(harness, params):
    """A trajectory whose points give velocities ends at rest; long after its end the published
    velocity is 0 and the force is the static force (once: the 0.5 m/s reported for ever and the
    353 N that came with it)."""
    from trajectory_msgs.msg import JointTrajectory

    harness.wait_connected()
    pub = harness.client.create_publisher(JointTrajectory, "/drs/trajectory_cmd", 10)
    assert spin_until(harness.exec, lambda: harness.node.sub_trajectory.get_publisher_count() > 0)
    pub.publish(_trajectory(["drs_piston"], [(0.02, [0.03], [0.5]), (0.04, [0.02], [0.0])]))
    assert spin_until(harness.exec, lambda: harness.node.effects.accepted >= 1, 3.0)
    spin_for(harness.exec, 0.3)
    last = harness.joints[-1]
    assert last.position[0] == pytest.approx(0.02, abs=1e-12)
    assert list(last.velocity) == [0.0, 0.0, 0.0]
    state = kin.kinematic_state(np.array([0.02]), np.zeros(1), np.zeros(1), params)
    static = float(inverse_dynamics(state, params).piston_force[0])
    assert last.effort[0] == pytest.approx(static, rel=1e-9)
    assert harness.forces[-1] == pytest.approx(static, rel=1e-9)


def test_diagnostics_recover_once_the_window_has_passed(ros_context, tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

    # 50 Hz publishing: a tick is late only past 30 ms, so a loaded test machine does not keep
    # the node in WARN for missed deadlines; a 3 s window: a stalled test process (a tick 466 ms
    # late was seen) may publish its next diagnostics more than 1 s after the refusal
    h = Harness(
        ros_context,
        [Parameter("diagnostics_window", value=3.0), Parameter("publish_rate_hz", value=50.0)],
    )
    levels: list[tuple[bytes, str]] = []
    h.client.create_subscription(
        DiagnosticArray,
        "/diagnostics",
        lambda m: levels.append((m.status[0].level, m.status[0].message)),
        10,
    )
    try:
        h.wait_connected()
        assert spin_until(h.exec, lambda: any(lv == DiagnosticStatus.OK for lv, _ in levels), 10.0)
        h.stroke_pub.publish(Float64(data=math.nan))
        assert spin_until(h.exec, lambda: h.node.effects.refused == 1, 3.0)
        n = len(levels)
        assert spin_until(h.exec, lambda: len(levels) > n, 3.0)
        level, message = levels[-1]
        assert level == DiagnosticStatus.WARN and "stroke command must be finite" in message
        # the window (3 s) passes: the refusal leaves the status (back to OK, unless a loaded
        # machine made a tick late within the window: that trouble is its own), and the
        # cumulative count stays in the key-values
        assert spin_until(h.exec, lambda: "refused" not in levels[-1][1], 12.0)
        level, message = levels[-1]
        assert level == DiagnosticStatus.OK or "missed deadline" in message, message
        assert h.node.diagnostics_values()["refused_commands"] == 1
    finally:
        h.close()


def test_an_integer_for_a_double_parameter_is_accepted(ros_context):
    overrides = [Parameter("publish_rate_hz", value=500)]
    node = DRSNode(context=ros_context, parameter_overrides=overrides)
    try:
        assert node.publish_period == pytest.approx(1 / 500)
        assert node.get_parameter("publish_rate_hz").type_ == Parameter.Type.DOUBLE
    finally:
        node.destroy_node()


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        (
            [Parameter("publish_rate", value=500.0)],
            r"unknown parameter 'publish_rate'; did you "
            r"mean 'publish_rate_hz'\?",
        ),
        ([Parameter("model.Iz_wnig", value=0.08)], r"did you mean 'model.Iz_wing'\?"),
        (
            [Parameter("publish_rate_hz", value=1500.0)],
            r"publish_rate_hz 1500 exceeds "
            r"physics_rate_hz 1000",
        ),
        ([Parameter("executor", value="events")], r"executor must be one of"),
        ([Parameter("tick_cpu", value=1023)], r"tick_cpu 1023 refused by the system"),
    ],
)
def test_parameters_that_would_run_the_actuator_wrongly_are_refused(ros_context, overrides, match):
    from drs_ros.node import StartupError

    with pytest.raises(StartupError, match=match):
        DRSNode(context=ros_context, parameter_overrides=overrides)
