"""The command line that starts drs-node, as rcl reads it: each parameter reaches a node with
its name, its value and its type, drs-node's own options stay outside the ROS arguments, and
a path with a space stays one argument."""

from __future__ import annotations

import pytest
from ros_support import require_rclpy

from drs_ros.node.command_line import PYTHON_M_DRS_ROS, node_command

pytestmark = pytest.mark.ros

require_rclpy()

from rclpy.context import Context  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.utilities import remove_ros_args  # noqa: E402


def _as_rcl_reads_it(argv: list[str]) -> tuple[dict[str, object], list[str]]:
    """The parameters a node built from ``argv`` holds (rcl's parsing of ``-p``, the same
    parser drs-node's process uses) and the arguments that are not ROS arguments."""
    ctx = Context()
    ctx.init(argv, domain_id=0)
    try:
        node = Node(
            "drs",
            context=ctx,
            start_parameter_services=False,
            automatically_declare_parameters_from_overrides=True,
        )
        try:
            held = {p.name: p.value for p in node.get_parameters_by_prefix("").values()}
        finally:
            node.destroy_node()
        return held, remove_ros_args(argv)
    finally:
        ctx.try_shutdown()


def test_parameters_reach_the_node_with_their_types(tmp_path):
    bag = tmp_path / "a bag"
    argv = node_command(
        {"bag_path": bag, "publish_rate_hz": 500.0, "flush_period": 0.2, "use_sim_time": True},
        options=["--managed"],
        ros_args=["-r", "__node:=drs"],
    )
    held, others = _as_rcl_reads_it(argv)
    assert held["bag_path"] == str(bag)
    assert held["publish_rate_hz"] == 500.0 and isinstance(held["publish_rate_hz"], float)
    assert held["flush_period"] == 0.2
    assert held["use_sim_time"] is True
    assert others == [*PYTHON_M_DRS_ROS, "--managed"]


def test_another_program_and_no_parameters():
    argv = node_command(program=["/opt/drs/lib/drs/drs-node"])
    assert argv == ["/opt/drs/lib/drs/drs-node", "--ros-args"]
    held, others = _as_rcl_reads_it(argv)
    assert others == ["/opt/drs/lib/drs/drs-node"]
    assert held == _as_rcl_reads_it(["drs-node"])[0]  # only what every rclpy node declares
