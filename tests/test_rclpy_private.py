"""drs_ros.rclpy_private, the only module that touches rclpy's private names: each helper does
what the node relies on, on the installed rclpy. A failure here means an rclpy upgrade changed
one of them (the module docstring says what each is for)."""

from __future__ import annotations

import inspect

from ros_support import require_rclpy

require_rclpy()

from action_msgs.msg import GoalStatus  # noqa: E402
from control_msgs.action import FollowJointTrajectory  # noqa: E402
from node_support import spin_until  # noqa: E402
from rclpy.action import ActionClient, ActionServer, GoalResponse  # noqa: E402
from rclpy.action.server import ServerGoalHandle  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from drs_ros import rclpy_private  # noqa: E402


def test_parameter_overrides_are_the_values_declare_parameter_takes(ros_context):
    given = [Parameter("rate", Parameter.Type.INTEGER, 500), Parameter("misspelt", value=1.0)]
    node = Node("probe", context=ros_context, parameter_overrides=given)
    try:
        overrides = rclpy_private.parameter_overrides(node)
        # an undeclared name is seen before any declaration: the node's misspelt-name check
        assert set(overrides) >= {"rate", "misspelt"}
        assert overrides["rate"].value == 500
        # a change is what declare_parameter then takes: the node's int -> float coercion
        overrides["rate"] = Parameter("rate", Parameter.Type.DOUBLE, 500.0)
        node.declare_parameter("rate", 250.0)
        assert node.get_parameter("rate").type_ == Parameter.Type.DOUBLE
        assert node.get_parameter("rate").value == 500.0
    finally:
        node.destroy_node()


def test_goal_helpers_have_the_signatures_the_action_server_calls():
    # the private members rclpy_private calls, as the pinned rclpy defines them
    assert list(inspect.signature(ServerGoalHandle._update_state).parameters) == ["self", "event"]
    assert list(inspect.signature(ActionServer.notify_execute).parameters) == [
        "self",
        "goal_handle",
        "execute_callback",
    ]


def test_a_goal_marked_executing_ends_through_the_scheduled_result(ros_context):
    """mark_executing: ACCEPTED -> EXECUTING and no callback runs; schedule_result: the
    callback runs in the executor, sets the terminal state and its return is the result."""
    server_node = Node("probe_server", context=ros_context)
    client_node = Node("probe_client", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(server_node)
    ex.add_node(client_node)
    handles, ran = [], []

    def finish(handle):
        ran.append(handle.status)
        handle.abort()
        return FollowJointTrajectory.Result(error_code=-4, error_string="probe")

    server = ActionServer(
        server_node,
        FollowJointTrajectory,
        "probe_action",
        execute_callback=finish,
        goal_callback=lambda _g: GoalResponse.ACCEPT,
        handle_accepted_callback=handles.append,
    )
    client = ActionClient(client_node, FollowJointTrajectory, "probe_action")
    try:
        assert spin_until(ex, client.server_is_ready, 10.0)
        sent = client.send_goal_async(FollowJointTrajectory.Goal())
        assert spin_until(ex, lambda: sent.done() and handles, 10.0)
        handle = handles[0]
        assert handle.status == GoalStatus.STATUS_ACCEPTED
        rclpy_private.mark_executing(handle)
        assert handle.status == GoalStatus.STATUS_EXECUTING
        ex.spin_once(timeout_sec=0.1)
        assert ran == []  # nothing scheduled yet
        result = sent.result().get_result_async()
        rclpy_private.schedule_result(server, handle, finish)
        assert spin_until(ex, result.done, 10.0)
        assert ran == [GoalStatus.STATUS_EXECUTING]
        assert result.result().status == GoalStatus.STATUS_ABORTED
        assert result.result().result.error_string == "probe"
    finally:
        client.destroy()
        server.destroy()
        ex.shutdown()
        server_node.destroy_node()
        client_node.destroy_node()


def test_log_for_callers_makes_rclpy_name_the_frame_that_called_into_the_module(tmp_path):
    """A line logged through a registered module is rclpy's caller's, not the module's: rclpy
    identifies the caller by file (``CallerId``) and keys its logger's state on it."""
    import importlib.util

    import rclpy.logging

    helper = tmp_path / "drs_log_helper.py"
    helper.write_text("def log(logger, text):\n    logger.info(text)\n")
    spec = importlib.util.spec_from_file_location("drs_log_helper", helper)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    logger = rclpy.logging.get_logger("drs_test_log_for_callers")
    module.log(logger, "before (logged by the test on purpose)")
    assert {c.function_name for c in logger.contexts} == {"log"}  # the helper's own line
    rclpy_private.log_for_callers(str(helper))
    rclpy_private.log_for_callers(str(helper))  # registered once, not twice
    from rclpy.impl.rcutils_logger import _internal_callers

    assert _internal_callers.count(str(helper.resolve())) == 1
    module.log(logger, "after (logged by the test on purpose)")
    names = {c.function_name for c in logger.contexts}
    assert names == {"log", inspect.currentframe().f_code.co_name}
