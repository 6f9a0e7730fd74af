"""The node in a vehicle stack, over real DDS (loopback only), as clients that know only the
standard interfaces see it: control_msgs' FollowJointTrajectory action with
joint_trajectory_controller's behaviour, /tf and /tf_static composed along the tree,
/robot_description, and ros2_control's topic interface (JointState commands by name)."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from node_support import NodeAndClient, spin_for, spin_until
from ros_support import require_module, require_rclpy, resimulate_json

pytestmark = pytest.mark.ros

require_rclpy()

from action_msgs.msg import GoalStatus  # noqa: E402
from control_msgs.action import FollowJointTrajectory  # noqa: E402
from control_msgs.msg import JointTolerance  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64, String  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402
from trajectory_msgs.msg import JointTrajectoryPoint  # noqa: E402

from drs_model import kinematics as kin  # noqa: E402

Result = FollowJointTrajectory.Result
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Stack(NodeAndClient):
    """The node and a client node that knows only standard interfaces, in one executor."""

    def __init__(self, ctx, overrides=()):
        super().__init__(ctx, overrides, "vehicle_stack")
        c = self.client
        self.joints, self.tf, self.tf_static, self.description = [], [], [], []
        c.create_subscription(JointState, "/joint_states", self.joints.append, 100)
        c.create_subscription(TFMessage, "/tf", self.tf.append, 100)
        c.create_subscription(TFMessage, "/tf_static", self.tf_static.append, LATCHED)
        c.create_subscription(String, "/robot_description", self.description.append, LATCHED)
        self.events = []
        from diagnostic_msgs.msg import DiagnosticArray

        c.create_subscription(
            DiagnosticArray, "/drs/command_events", lambda m: self.events.extend(m.status), 100
        )
        self.commands = c.create_publisher(JointState, "/drs/joint_commands", 10)
        self.force = c.create_publisher(Float64, "/drs/force_cmd", 10)
        self.action = ActionClient(c, FollowJointTrajectory, "/drs/follow_joint_trajectory")

    def ready(self):
        assert spin_until(self.exec, lambda: len(self.joints) > 3, 10.0), "no /joint_states"
        assert self.action.wait_for_server(timeout_sec=5.0)
        assert spin_until(self.exec, lambda: self.commands.get_subscription_count() > 0, 5.0)

    def send(self, goal, feedback=None):
        fut = self.action.send_goal_async(goal, feedback_callback=feedback)
        assert spin_until(self.exec, fut.done, 5.0), "no goal response"
        handle = fut.result()
        assert handle.accepted  # drs answers an invalid goal with a result, not a rejection
        return handle

    def result(self, handle, timeout=5.0):
        fut = handle.get_result_async()
        assert spin_until(self.exec, fut.done, timeout), "no result"
        return fut.result()


@pytest.fixture
def stack(ros_context, tmp_path):
    s = Stack(ros_context, [Parameter("bag_path", value=str(tmp_path / "bag"))])
    yield s
    s.close()


def goal_of(points, joints=("drs_piston",), path=(), goal_tol=(), goal_time=0.0, stamp_ns=0):
    """A FollowJointTrajectory goal: ``points`` = [(t [s], s [m]), ...]."""
    g = FollowJointTrajectory.Goal()
    g.trajectory.joint_names = list(joints)
    g.trajectory.header.stamp.sec, g.trajectory.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    for t, s in points:
        pt = JointTrajectoryPoint(positions=[s] * len(joints))
        pt.time_from_start.sec, ns = divmod(round(t * 1e9), 10**9)
        pt.time_from_start.nanosec = ns
        g.trajectory.points.append(pt)
    g.path_tolerance = [JointTolerance(name=n, position=v) for n, v in path]
    g.goal_tolerance = [JointTolerance(name=n, position=v) for n, v in goal_tol]
    g.goal_time_tolerance.sec, ns = divmod(round(goal_time * 1e9), 10**9)
    g.goal_time_tolerance.nanosec = ns
    return g


def test_a_goal_reaches_its_points_with_feedback_at_the_publish_rate(stack, params):
    stack.ready()
    feedback = []
    handle = stack.send(goal_of([(0.05, 0.02), (0.1, 0.03)]), lambda m: feedback.append(m.feedback))
    res = stack.result(handle)
    assert res.status == GoalStatus.STATUS_SUCCEEDED
    assert res.result.error_code == Result.SUCCESSFUL
    # the last point, exactly (a move ends at rest); the result and the joint state of the same
    # tick travel on different DDS entities, so either may arrive first
    assert spin_until(stack.exec, lambda: stack.joints[-1].position[0] == 0.03, 1.0)

    # feedback comes with every published joint state while the goal runs (0.1 s of simulated
    # time: ~25 at 250 Hz, fewer when a loaded machine delays ticks)
    def ns(stamp):
        return stamp.sec * 10**9 + stamp.nanosec

    fb_stamps = [ns(f.header.stamp) for f in feedback]
    window = [
        ns(m.header.stamp)
        for m in stack.joints
        if fb_stamps[0] <= ns(m.header.stamp) <= fb_stamps[-1]
    ]
    assert fb_stamps == window and len(fb_stamps) >= 5
    fb = feedback[len(feedback) // 2]
    assert list(fb.joint_names) == ["drs_piston"]
    assert fb.error.positions[0] == fb.desired.positions[0] - fb.actual.positions[0]
    assert abs(fb.error.positions[0]) < 1e-12  # the simulated piston follows its plan
    # actual is a joint state the node published (same stroke at the same stamp)
    by_stamp = {(m.header.stamp.sec, m.header.stamp.nanosec): m.position[0] for m in stack.joints}
    stamp = (fb.header.stamp.sec, fb.header.stamp.nanosec)
    assert by_stamp[stamp] == fb.actual.positions[0]
    times = [
        f.actual.time_from_start.sec + 1e-9 * f.actual.time_from_start.nanosec for f in feedback
    ]
    assert all(b > a for a, b in zip(times, times[1:], strict=False))


@pytest.mark.parametrize(
    ("joints", "code", "words"),
    [
        (("drs_flap",), Result.INVALID_JOINTS, "drs_flap"),
        (("drs_piston", "drs_link"), Result.INVALID_JOINTS, "drs_link"),
        (("wheel",), Result.INVALID_JOINTS, "wheel"),
    ],
)
def test_a_goal_with_a_wrong_joint_gets_invalid_joints(stack, joints, code, words):
    stack.ready()
    res = stack.result(stack.send(goal_of([(0.05, 0.02)], joints=joints)))
    assert res.status == GoalStatus.STATUS_ABORTED
    assert res.result.error_code == code
    assert words in res.result.error_string and "drs_piston" in res.result.error_string
    assert stack.joints[-1].position[0] == pytest.approx(kin.stroke_limits(stack.node.params)[0])


def test_invalid_goals_get_their_codes_and_leave_the_actuator_alone(stack, params):
    stack.ready()
    s_max = kin.stroke_limits(params)[1]
    bad_time = goal_of([(0.05, 0.02), (0.05, 0.03)])  # not strictly increasing
    past = goal_of([(0.01, 0.02)], stamp_ns=stack.node.get_clock().now().nanoseconds - 10**9)
    cases = [
        (goal_of([]), Result.INVALID_GOAL, "empty"),
        (bad_time, Result.INVALID_GOAL, "increase strictly"),
        (goal_of([(0.05, s_max + 1e-3)]), Result.INVALID_GOAL, "outside [s_min, s_max]"),
        (past, Result.OLD_HEADER_TIMESTAMP, "past"),
    ]
    for goal, code, words in cases:
        res = stack.result(stack.send(goal))
        assert (res.status, res.result.error_code) == (GoalStatus.STATUS_ABORTED, code), words
        assert words in res.result.error_string, res.result.error_string

    def refused() -> int:
        return sum(any(kv.value == "refused" for kv in s.values) for s in stack.events)

    assert spin_until(stack.exec, lambda: refused() >= 4, 5.0), refused()  # in the effect record
    assert stack.node.sim.mode == "hold"


def test_a_violated_path_tolerance_aborts_with_its_code(stack, params):
    """A force command takes the actuator mid-trajectory (latest wins): the piston leaves the
    goal's path, and the path tolerance aborts the goal, as JTC's would."""
    stack.ready()
    handle = stack.send(goal_of([(0.3, 0.04)], path=[("drs_piston", 1e-3)]))
    spin_for(stack.exec, 0.1)
    stack.force.publish(Float64(data=-500.0))  # pulls the flap back towards closed
    res = stack.result(handle)
    assert res.status == GoalStatus.STATUS_ABORTED
    assert res.result.error_code == Result.PATH_TOLERANCE_VIOLATED
    assert "drs_piston position error" in res.result.error_string
    assert "path tolerance 0.001 m" in res.result.error_string
    # the newer command stays in force: the abort did not hold the piston over it
    spin_for(stack.exec, 0.05)
    assert stack.node.sim.mode == "force"


def test_a_violated_goal_tolerance_aborts_after_goal_time(stack, params):
    stack.ready()
    handle = stack.send(goal_of([(0.15, 0.02)], goal_tol=[("drs_piston", 1e-4)], goal_time=0.05))
    spin_for(stack.exec, 0.05)
    stack.force.publish(Float64(data=1500.0))  # onto the open stop, past the goal
    res = stack.result(handle)
    assert res.status == GoalStatus.STATUS_ABORTED
    assert res.result.error_code == Result.GOAL_TOLERANCE_VIOLATED
    assert "goal_time_tolerance" in res.result.error_string
    assert "goal tolerance 0.0001 m" in res.result.error_string


def test_a_new_goal_preempts_the_active_one(stack, params):
    stack.ready()
    first = stack.send(goal_of([(0.5, 0.04)]))
    spin_for(stack.exec, 0.05)
    second = stack.send(goal_of([(0.05, 0.01)]))
    res1 = stack.result(first)
    assert res1.status == GoalStatus.STATUS_ABORTED
    assert res1.result.error_code == Result.INVALID_GOAL
    assert res1.result.error_string == "Current goal preempted by new incoming action."
    res2 = stack.result(second)
    assert res2.status == GoalStatus.STATUS_SUCCEEDED
    assert spin_until(stack.exec, lambda: stack.joints[-1].position[0] == 0.01, 1.0)


def test_an_invalid_goal_does_not_preempt(stack, params):
    stack.ready()
    first = stack.send(goal_of([(0.2, 0.03)]))
    spin_for(stack.exec, 0.03)
    bad = stack.result(stack.send(goal_of([(0.05, 0.03)], joints=("drs_flap",))))
    assert bad.result.error_code == Result.INVALID_JOINTS
    res = stack.result(first)
    assert res.status == GoalStatus.STATUS_SUCCEEDED
    assert spin_until(stack.exec, lambda: stack.joints[-1].position[0] == 0.03, 1.0)


def test_cancel_holds_the_current_position(stack, params):
    stack.ready()
    handle = stack.send(goal_of([(0.4, 0.04)]))
    spin_for(stack.exec, 0.15)
    fut = handle.cancel_goal_async()
    assert spin_until(stack.exec, fut.done, 5.0)
    assert len(fut.result().goals_canceling) == 1
    res = stack.result(handle)
    assert res.status == GoalStatus.STATUS_CANCELED
    # the hold is in the effect record: a move back to the stroke where the goal was cancelled
    assert spin_until(
        stack.exec, lambda: any(_value(s, "value") == "hold" for s in stack.events), 2.0
    )
    hold = next(s for s in stack.events if _value(s, "value") == "hold")
    target = float(_value(hold, "target"))
    step = int(_value(hold, "step"))
    spin_for(stack.exec, float(_value(hold, "duration")) + 0.05)
    assert stack.joints[-1].position[0] == target and stack.joints[-1].velocity[0] == 0.0
    # the target is the stroke published at the cancelling step (the joint state of that step)
    t0_ns = stack.node.clock.t0_ns
    at = {
        round((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - t0_ns) / 1e6): m.position[0]
        for m in stack.joints
    }
    assert at[step] == target
    assert 0.001 < target < 0.04


def _value(status, key):
    return next((kv.value for kv in status.values if kv.key == key), None)


def test_tf_composed_along_the_tree_puts_the_pin_where_kinematics_does(stack, params):
    stack.ready()
    stack.send(goal_of([(0.05, 0.025)]))
    assert spin_until(stack.exec, lambda: stack.tf_static and len(stack.tf) > 20, 5.0)
    static = {t.child_frame_id: t for m in stack.tf_static for t in m.transforms}
    assert static["drs_base"].header.frame_id == "base_link"  # the mount
    checked = 0
    by_stamp = {(m.header.stamp.sec, m.header.stamp.nanosec): m for m in stack.joints}
    for msg in stack.tf[-20:]:
        moving = {t.child_frame_id: t for t in msg.transforms}
        stamp = msg.transforms[0].header.stamp
        joint_state = by_stamp.get((stamp.sec, stamp.nanosec))
        if joint_state is None:
            continue
        q = np.array(joint_state.position)
        frames = {**static, **moving}
        pts = kin.point_positions(q, params)
        pin = compose(frames, "drs_flap_pin", "drs_base")
        tip = compose(frames, "drs_link_tip", "drs_base")
        assert np.abs(pin[:2, 3] - pts["C3"]).max() < 1e-12
        assert np.abs(tip[:2, 3] - pts["C3"]).max() < 1e-12  # the cut loop closes
        assert np.abs(compose(frames, "drs_piston_rod", "drs_base")[:2, 3] - pts["P"]).max() < 1e-15
        checked += 1
    assert checked >= 10
    # the mount: drs_base's y (up) is base_link's z
    mount = compose(static, "drs_base", "base_link")
    assert np.allclose(mount[:3, 1], [0, 0, 1], atol=1e-15)


def bag_stamps(bag, topic: str) -> list[int]:
    """The header stamps [ns] of a bag's messages on ``topic`` (a JointState or a TFMessage, its
    first transform's), decoded with rclpy."""
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message

    msg_type = TFMessage if topic == "/tf" else JointState
    out = []
    for file in sorted(bag.glob("*.mcap")):
        with open(file, "rb") as f:
            for _schema, _channel, message in make_reader(f).iter_messages(topics=[topic]):
                msg = deserialize_message(message.data, msg_type)
                stamp = (msg.transforms[0] if topic == "/tf" else msg).header.stamp
                out.append(stamp.sec * 1_000_000_000 + stamp.nanosec)
    return out


def compose(frames, child: str, root: str) -> np.ndarray:
    """The 4x4 pose of ``child`` in ``root``, composing TransformStamped parent by parent."""
    out = np.eye(4)
    while child != root:
        t = frames[child]
        out = _matrix(t.transform) @ out
        child = t.header.frame_id
    return out


def _matrix(tr) -> np.ndarray:
    x, y, z, w = tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w
    m = np.eye(4)
    m[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    m[:3, 3] = [tr.translation.x, tr.translation.y, tr.translation.z]
    return m


def test_robot_description_is_latched_and_parses(stack, params):
    yourdfpy = require_module("yourdfpy")
    stack.ready()
    assert spin_until(stack.exec, lambda: stack.description, 5.0)  # a late subscriber gets it
    urdf = yourdfpy.URDF.load(io.StringIO(stack.description[0].data), load_meshes=False)
    assert list(urdf.actuated_joint_names) == list(stack.node.joint_names)
    lim = {j.name: j.limit for j in urdf.robot.joints}["drs_piston"]
    assert (lim.lower, lim.upper) == kin.stroke_limits(params)


def joint_command(names, position=(), effort=(), velocity=()):
    return JointState(
        name=list(names), position=list(position), effort=list(effort), velocity=list(velocity)
    )


def test_joint_state_commands_move_and_push_the_piston(stack, params):
    stack.ready()
    # as JointStateTopicSystem writes it: every joint named, the piston's command only
    stack.commands.publish(joint_command(["drs_piston", "drs_link", "drs_flap"], position=[0.03]))
    assert spin_until(stack.exec, lambda: stack.joints[-1].position[0] == 0.03, 3.0)
    # a plain JointState: one value per name, NaN for the passive joints; effort -> force mode
    stack.commands.publish(joint_command(["drs_link", "drs_piston"], effort=[math.nan, 1500.0]))
    assert spin_until(stack.exec, lambda: stack.node.sim.mode == "force", 3.0)
    s_max = kin.stroke_limits(params)[1]
    assert spin_until(stack.exec, lambda: stack.joints[-1].position[0] == s_max, 3.0)
    assert stack.joints[-1].effort[0] == 1500.0  # the piston force is the commanded effort


@pytest.mark.parametrize(
    ("command", "words"),
    [
        (joint_command(["drs_piston"], position=[0.5]), "outside [s_min, s_max]"),
        (joint_command(["drs_piston"], position=[math.nan]), "exactly one finite value"),
        (joint_command(["drs_piston"], effort=[4.0e4]), "outside [-30000, 30000] N"),
        (joint_command(["drs_piston", "drs_flap"], position=[0.02, 0.7]), "passive"),
        (joint_command(["drs_piston"], velocity=[0.1]), "no velocity"),
        (joint_command(["drs_flap"], position=[0.7]), "must name 'drs_piston'"),
        (joint_command(["drs_piston"], position=[0.02], effort=[10.0]), "exactly one"),
    ],
)
def test_joint_state_commands_are_refused_like_the_other_paths(stack, command, words):
    stack.ready()
    stack.commands.publish(command)
    assert spin_until(stack.exec, lambda: stack.node.effects.refused >= 1, 3.0)
    assert words in stack.node.effects.last_refusal, stack.node.effects.last_refusal
    assert stack.node.sim.mode == "hold"


def test_joint_command_refusals_match_stroke_cmd(stack, ros_context):
    """The same out-of-range stroke gets the same reason on both paths."""
    stack.ready()
    stack.commands.publish(joint_command(["drs_piston"], position=[0.5]))
    assert spin_until(stack.exec, lambda: stack.node.effects.refused >= 1, 3.0)
    by_joint = stack.node.effects.last_refusal.split("refused: ", 1)[1]
    pub = stack.client.create_publisher(Float64, "/drs/stroke_cmd", 10)
    spin_until(stack.exec, lambda: pub.get_subscription_count() > 0, 3.0)
    pub.publish(Float64(data=0.5))
    assert spin_until(stack.exec, lambda: stack.node.effects.refused >= 2, 3.0)
    assert stack.node.effects.last_refusal.split("refused: ", 1)[1] == by_joint


def test_a_bag_of_the_action_tf_and_joint_commands_checks_and_re_runs(ros_context, tmp_path):
    """drs-bag check passes, rosbags and mcap_ros2 read every message byte-exact (/tf,
    /tf_static, /robot_description, the JointState commands), and the run re-runs exactly: the
    goals' moves and the holds are in the effect record."""
    import subprocess
    import sys

    from test_bag_tools import judge_with_mcap_ros2, judge_with_rosbags

    bag = tmp_path / "bag"
    stack = Stack(ros_context, [Parameter("bag_path", value=str(bag))])
    try:
        stack.ready()
        assert stack.result(stack.send(goal_of([(0.04, 0.02), (0.08, 0.03)]))).status == 4
        first = stack.send(goal_of([(0.3, 0.045)]))
        spin_for(stack.exec, 0.05)
        second = stack.send(goal_of([(0.3, 0.04)]))  # preempts the first
        spin_for(stack.exec, 0.05)
        assert spin_until(stack.exec, second.cancel_goal_async().done, 5.0)  # cancel: a hold
        assert stack.result(first).result.error_code == Result.INVALID_GOAL
        assert stack.result(second).status == GoalStatus.STATUS_CANCELED
        spin_for(stack.exec, 0.05)
        stack.commands.publish(joint_command(["drs_piston"], position=[0.01]))
        spin_for(stack.exec, 0.1)
        stack.commands.publish(joint_command(["drs_piston"], effort=[1200.0]))
        spin_for(stack.exec, 0.1)
        stack.commands.publish(joint_command(["drs_piston"], position=[0.9]))  # refused
        stack.result(stack.send(goal_of([(0.05, 0.02)], joints=("drs_flap",))))  # refused
        spin_for(stack.exec, 0.1)
    finally:
        stack.close()
    check = subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.cli", "check", str(bag)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert check.returncode == 0, check.stdout + check.stderr
    by_rosbags, by_mcap = judge_with_rosbags(bag), judge_with_mcap_ros2(bag)
    assert by_rosbags == by_mcap
    assert by_rosbags["/robot_description"] == by_rosbags["/tf_static"] == 1
    # /tf at tf_rate_hz (100 Hz), each the transforms of a recorded joint state
    tf, joints = bag_stamps(bag, "/tf"), bag_stamps(bag, "/joint_states")
    assert set(tf) <= set(joints)
    span_periods = (joints[-1] - joints[0]) / 10_000_000  # 10 ms: tf_rate_hz's period
    assert 0.8 * span_periods <= len(tf) <= span_periods + 2  # a stall of the test may skip one
    assert by_rosbags["/drs/joint_commands"] == 3
    status, report = resimulate_json(str(bag))
    assert status == 0, report
    assert all(r["max_deviation"] == 0.0 for r in report["signals"]), report["signals"]
    assert not report["notes"]


def test_a_joint_command_with_uninitialised_padding_is_taken_and_recorded_exact(
    ros_context, tmp_path
):
    """Fast DDS leaves a JointState's alignment padding uninitialised; such a command is well
    formed: it is taken, and the bag holds its exact CDR (padding zero)."""
    from decoded_support import read_bag

    from drs_ros.recording import cdr

    bag = tmp_path / "bag"
    stack = Stack(ros_context, [Parameter("bag_path", value=str(bag))])
    try:
        stack.ready()
        exact = cdr.serializer(JointState)(joint_command(["drs_piston"], position=[0.025]))
        dirty = bytearray(exact)
        assert dirty[17:20] == b"\0\0\0"  # the padding after the empty frame_id's terminator
        dirty[17:20] = b"\xab\xcd\xef"
        raw = stack.client.create_publisher(JointState, "/drs/joint_commands", 10)
        assert spin_until(stack.exec, lambda: raw.get_subscription_count() > 0, 3.0)
        raw.publish(bytes(dirty))
        assert spin_until(stack.exec, lambda: stack.joints[-1].position[0] == 0.025, 3.0)
        assert stack.node.effects.refused == 0
    finally:
        stack.close()
    from drs_ros.bag.read.reader import scan

    recorded = []
    scan(bag, lambda m: recorded.append(bytes(m.data)), topics={"/drs/joint_commands"})
    assert recorded == [exact]
    read_bag(bag, ["/drs/joint_commands"])  # and the bag verifies, every byte


def test_feedback_times_are_exact_across_whole_seconds(ros_context):
    """A goal of 2.5 s on a clock the test sets (use_sim_time; a tick every 4 ms of node time,
    the publish period): the k-th feedback is exactly k publish periods after the goal started,
    in its header stamp and in the ``time_from_start`` of desired, actual and error, across
    1 s and 2 s. The goal starts at the node's simulated 0.156 s, where a float split of the
    time since the start (``t // 1`` and the rounded fraction) gave 0 s 0 ns at 1 s."""
    from rclpy.time import Time

    from drs_ros.timestamps import ns_of

    stack = Stack(ros_context, [Parameter("use_sim_time", value=True)])
    node, clock = stack.node, stack.node.get_clock()
    period_ns = round(node.publish_period * 1e9)
    assert period_ns == 4_000_000
    now = [1_000_000_000]

    def tick():
        clock.set_ros_time_override(Time(nanoseconds=now[0], clock_type=clock.clock_type))
        node.tick()
        now[0] += period_ns
        stack.exec.spin_once(timeout_sec=0.0)

    try:
        for _ in range(39):  # the simulation reaches 0.152 s
            tick()
        assert node.sim.steps == 152
        assert stack.action.wait_for_server(timeout_sec=5.0)
        feedback = []
        s0 = float(node.sim.state.q[0])
        handle = stack.send(
            goal_of([(1.0, s0 + 0.01), (2.5, s0 + 0.02)]), lambda m: feedback.append(m.feedback)
        )
        result = handle.get_result_async()
        while not result.done() and now[0] < 4_000_000_000:
            seen = len(feedback)
            tick()  # the first takes the goal, at step 156
            spin_until(stack.exec, lambda seen=seen: len(feedback) > seen or result.done(), 2.0)
        assert result.done() and result.result().status == GoalStatus.STATUS_SUCCEEDED
    finally:
        stack.close()
    since = [ns_of(f.header.stamp) - ns_of(feedback[0].header.stamp) for f in feedback]
    assert since == [k * period_ns for k in range(len(feedback))]  # none lost
    for f, expected in zip(feedback, since, strict=True):
        for point in (f.desired, f.actual, f.error):
            assert ns_of(point.time_from_start) == expected
            assert 0 <= point.time_from_start.nanosec < 1_000_000_000
    assert {1_000_000_000, 2_000_000_000} <= set(since) and since[-1] >= 2_500_000_000
