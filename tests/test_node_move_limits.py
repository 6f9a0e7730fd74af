"""Moves within the actuator, at the node over real DDS (loopback only): a goal or a trajectory
whose inverse-dynamics peak exceeds ``force_limit`` is refused with the peak and the limit, the
seed's manoeuvre is taken with the default parameters, a short stroke command is timed within
the limit and the force published along it is the force of that motion; a goal whose only
point is at 0 s and a deactivation behave as joint_trajectory_controller's."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from node_support import domain_for, node_env, spin_for, spin_until
from ros_support import require_rclpy, resimulate_json

pytestmark = pytest.mark.ros

require_rclpy()

from action_msgs.msg import GoalStatus  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402
from test_node_stack import Result, Stack, goal_of  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

from drs_model import kinematics as kin  # noqa: E402
from drs_model.inverse import inverse_dynamics  # noqa: E402


def _resimulated(bag) -> dict:
    """``drs-bag resimulate`` of ``bag`` (asserted to exit 0): its rows by signal."""
    status, report = resimulate_json(str(bag))
    assert status == 0, report
    return {r["signal"]: r for r in report["signals"]}


def _newton_euler(params, s, sd, sdd) -> np.ndarray:
    state = kin.kinematic_state(np.atleast_1d(s), np.atleast_1d(sd), np.atleast_1d(sdd), params)
    return inverse_dynamics(state, params, "newton-euler").piston_force


def test_a_2ms_full_stroke_goal_is_refused_with_the_peak_and_the_limit(ros_context, params):
    """The default force_limit (30 kN) and limit_moves: a full stroke in 2 ms (0.61 MN) is an
    INVALID_GOAL naming the peak and the limit, on the action and on ``~/trajectory_cmd``
    (refused and counted); the piston stays; the seed's DRS opening (25.4 kN) is taken."""
    st = Stack(ros_context)
    try:
        st.ready()
        assert st.node.get_parameter("limit_moves").value is True
        assert st.node.get_parameter("force_limit").value == 3.0e4
        s_min, s_max = kin.stroke_limits(params)
        res = st.result(st.send(goal_of([(0.002, s_max)])))
        assert res.status == GoalStatus.STATUS_ABORTED
        assert res.result.error_code == Result.INVALID_GOAL, res.result.error_string
        why = res.result.error_string
        peak = float(re.search(r"piston force of (\S+) N", why).group(1))
        assert abs(peak) > 5e5 and "beyond force_limit 30000 N" in why, why
        # the topic: the same refusal, counted
        pub = st.client.create_publisher(JointTrajectory, "/drs/trajectory_cmd", 10)
        assert spin_until(st.exec, lambda: pub.get_subscription_count() > 0, 5.0)
        refused = st.node.effects.refused
        msg = JointTrajectory(joint_names=["drs_piston"])
        pt = JointTrajectoryPoint(positions=[s_max])
        pt.time_from_start.nanosec = 2_000_000
        msg.points.append(pt)
        pub.publish(msg)
        assert spin_until(st.exec, lambda: st.node.effects.refused > refused, 3.0)
        assert "beyond force_limit 30000 N" in st.node.effects.last_refusal
        assert st.joints[-1].position[0] == pytest.approx(s_min, abs=1e-12)
        # the seed's opening, 25.4 kN in 10 ms, fits
        cli = st.client.create_client(SetBool, "/drs/drs")
        assert cli.wait_for_service(timeout_sec=5.0)
        fut = cli.call_async(SetBool.Request(data=True))
        assert spin_until(st.exec, fut.done, 5.0)
        assert fut.result().success, fut.result().message
        assert spin_until(st.exec, lambda: st.joints[-1].position[0] == s_max, 3.0)
    finally:
        st.close()


def test_the_force_published_along_a_fast_move_is_the_force_of_that_motion(ros_context, params):
    """A stroke command 20 mm off the closed stop (68 kN in the seed's 4.4 ms) is timed within
    the limit; every state published along it carries the Newton-Euler force of the path the
    node followed at that state's instant, within force_limit. The node publishes one state a
    tick: the move goes back and forth until a few states have landed inside it (a late tick
    on a loaded machine may skip one move)."""
    hz = 1000.0
    st = Stack(
        ros_context,
        [Parameter("physics_rate_hz", value=hz), Parameter("publish_rate_hz", value=hz)],
    )
    try:
        st.ready()
        s_min = kin.stroke_limits(params)[0]
        pub = st.client.create_publisher(Float64, "/drs/stroke_cmd", 10)
        assert spin_until(st.exec, lambda: pub.get_subscription_count() > 0, 5.0)
        t0_ns = st.node.clock.t0_ns
        along = []
        for target in [s_min + 0.02, s_min] * 5:
            seen = len(st.joints)
            pub.publish(Float64(data=target))
            assert spin_until(st.exec, lambda t=target: st.node.sim.motion.target == t, 3.0)
            path = st.node.sim.motion.path
            duration = path.t_end - path.t_start
            assert duration > 1.3 * params.T_opening * 0.02 / np.ptp(kin.stroke_limits(params))
            assert spin_until(st.exec, lambda t=target: st.joints[-1].position[0] == t, 3.0)
            for m in st.joints[seen:]:
                t = (m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - t0_ns) * 1e-9
                if path.t_start < t < path.t_end:
                    along.append((path.at(t), m.position[0], m.effort[0]))
            if len(along) >= 4:
                break
        assert len(along) >= 4, len(along)
        s_v_a, s, effort = (np.array(c) for c in zip(*along, strict=True))
        assert s == pytest.approx(s_v_a[:, 0], abs=1e-12)
        expected = _newton_euler(params, *s_v_a.T)
        assert effort == pytest.approx(expected, rel=1e-6, abs=1e-3)
        assert np.max(np.abs(effort)) <= 3.0e4
    finally:
        st.close()


def test_a_goal_of_one_point_at_0_s_moves_there_now(ros_context, params, tmp_path):
    """joint_trajectory_controller takes a single point at 0 s as the position to hold now
    (sampled at once); drs moves there in a stroke command's own time and the goal succeeds,
    on the action and on ``~/trajectory_cmd``; the bag re-runs both exactly (the action's
    record is the one-point trajectory taken; the topic's is timed again from the state)."""
    bag = tmp_path / "bag"
    st = Stack(ros_context, [Parameter("bag_path", value=str(bag))])
    try:
        st.ready()
        res = st.result(st.send(goal_of([(0.0, 0.03)])))
        assert res.status == GoalStatus.STATUS_SUCCEEDED, res.result.error_string
        assert st.joints[-1].position[0] == pytest.approx(0.03, abs=1e-12)
        path = st.node.sim.motion.path
        assert path.t_end - path.t_start >= params.T_opening * 0.03 / np.ptp(
            kin.stroke_limits(params)
        ) * (1 - 1e-12)
        # at the present state: nothing to move, it succeeds as it is
        res = st.result(st.send(goal_of([(0.0, 0.03)])))
        assert res.status == GoalStatus.STATUS_SUCCEEDED, res.result.error_string
        # the topic alike
        pub = st.client.create_publisher(JointTrajectory, "/drs/trajectory_cmd", 10)
        assert spin_until(st.exec, lambda: pub.get_subscription_count() > 0, 5.0)
        msg = JointTrajectory(joint_names=["drs_piston"])
        msg.points.append(JointTrajectoryPoint(positions=[0.01]))
        pub.publish(msg)
        assert spin_until(st.exec, lambda: st.joints[-1].position[0] == 0.01, 3.0)
        spin_for(st.exec, 0.1)
    finally:
        st.close()
    rows = _resimulated(bag)
    assert all(r["max_deviation"] == 0.0 for r in rows.values()), rows


def test_deactivation_holds_the_piston_where_it_is(ros_context, params, tmp_path):
    """Deactivated during a 0.6 s goal: the goal is aborted as joint_trajectory_controller
    aborts it, and once active again the piston comes to rest near where it was (the hold),
    not at the goal's end; the bag re-runs it exactly."""
    bag = tmp_path / "bag"
    st = Stack(ros_context, [Parameter("bag_path", value=str(bag))])
    try:
        st.ready()
        handle = st.send(goal_of([(0.6, 0.04)]))
        assert spin_until(st.exec, lambda: st.joints[-1].position[0] > 0.005, 3.0)
        st.node.deactivate()
        res = st.result(handle)
        assert (res.status, res.result.error_code) == (
            GoalStatus.STATUS_ABORTED,
            Result.INVALID_GOAL,
        )
        assert res.result.error_string == "Current goal cancelled during deactivate transition."
        held_from = float(st.node.sim.state.q[0])
        target = st.node.sim.motion.target  # the hold's
        assert st.node.sim.motion.path.t_end > st.node.sim.t  # to be run once active
        assert abs(target - held_from) < 0.01  # where the piston was, not the goal's 40 mm
        st.node.activate()
        assert spin_until(st.exec, lambda: st.joints[-1].position[0] == target, 3.0)
        spin_for(st.exec, 0.1)
        assert st.joints[-1].position[0] == target and st.joints[-1].velocity[0] == 0.0
    finally:
        st.close()
    rows = _resimulated(bag)
    assert all(r["max_deviation"] == 0.0 for r in rows.values()), rows


#: In a fresh interpreter: a configured node, then whether the compiled path scan a command's
#: force check runs, and its path's hull check, are already loaded (a signature loaded from
#: numba's cache). ``auto`` is left out: its choice measures the rungs at configure, which
#: loads the scan anyway.
_FIRST_COMMAND = """
import sys
import rclpy
from rclpy.parameter import Parameter
from drs_ros.node import DRSNode
from drs_model.inverse import path_peak
from drs_model import path_range
ctx = rclpy.Context()
rclpy.init(context=ctx)
node = DRSNode(context=ctx, tick_timer=False, parameter_overrides=[
    Parameter("bag_path", value=sys.argv[1]), Parameter("fidelity", value=sys.argv[2])])
loaded = path_peak._scan.cache_info().currsize == 1 and len(path_peak._scan().signatures) == 1
loaded &= path_range._hull.cache_info().currsize == 1 and len(path_range._hull().signatures) == 1
print(loaded)
node.destroy_node()
rclpy.shutdown(context=ctx)
"""


@pytest.mark.skipif(
    importlib.util.find_spec("numba") is None and not os.environ.get("CI"),
    reason="numba is not installed (pip install drs[fast]): nothing is compiled to load",
)
@pytest.mark.parametrize("fidelity", ["rigid", "hydraulic"])
def test_the_force_check_a_command_runs_is_loaded_at_configure(tmp_path, request, fidelity):
    """The first command's tick would load it from numba's cache (~5 ms: a missed deadline at
    1 kHz or 250 Hz); configure loads it (the ``~/drs`` moves' check from rest)."""
    env = node_env(tmp_path, domain_for(request.node.nodeid))
    out = subprocess.run(
        [sys.executable, "-c", _FIRST_COMMAND, str(tmp_path / "bag"), fidelity],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[-1] == "True", out.stdout + out.stderr
