"""``drs-bag from-goal``: a FollowJointTrajectory goal file as a bag of the node's trajectory
command, read back by a reader we did not write (rosbags), under the node's name; a malformed
goal is the file's error naming the point, an existing output is refused and nothing is left
behind."""

from __future__ import annotations

import contextlib
import io
import re

import pytest
import yaml
from ros_support import require_rclpy

from drs_model.cli.exit_status import EXIT_OK, EXIT_UNREADABLE, EXIT_USAGE

#: A goal as ``drs excite -o`` writes it: two points of the piston joint.
GOAL = {
    "trajectory": {
        "joint_names": ["drs_piston"],
        "points": [
            {
                "positions": [0.01],
                "velocities": [0.2],
                "time_from_start": {"sec": 0, "nanosec": 50_000_000},
            },
            {"positions": [0.03], "velocities": [0.0], "time_from_start": {"sec": 1, "nanosec": 5}},
        ],
    }
}


def drs_bag(*args) -> tuple[int, str, str]:
    require_rclpy()
    from drs_ros.bag.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main([str(a) for a in args])
        except SystemExit as exc:
            status = exc.code
    return status, out.getvalue(), err.getvalue()


def _goal(tmp_path, goal=GOAL):
    path = tmp_path / "goal.yaml"
    path.write_text(yaml.safe_dump(goal))
    return path


def _read_with_rosbags(bag):
    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as reader:
        return [
            (c.topic, c.msgtype, reader.deserialize(raw, c.msgtype))
            for c, _t, raw in reader.messages()
        ]


@pytest.mark.parametrize(
    ("argv", "topic"),
    [
        ([], "/drs/trajectory_cmd"),
        (["--node", "/car7/drs_rear"], "/car7/drs_rear/trajectory_cmd"),
        (["--node", "car7/drs_rear"], "/car7/drs_rear/trajectory_cmd"),
        (["--topic", "/stack/drs_traj"], "/stack/drs_traj"),
    ],
)
def test_the_goal_is_the_bag_s_trajectory_command_on_the_node_s_topic(tmp_path, argv, topic):
    bag = tmp_path / "bag"
    status, out, err = drs_bag("from-goal", _goal(tmp_path), "-o", bag, *argv)
    assert status == EXIT_OK, err
    assert f"2 points of drs_piston on {topic}" in out
    assert (bag / "metadata.yaml").is_file()
    ((got_topic, msgtype, msg),) = _read_with_rosbags(bag)
    assert (got_topic, msgtype) == (topic, "trajectory_msgs/msg/JointTrajectory")
    assert list(msg.joint_names) == ["drs_piston"]
    points = GOAL["trajectory"]["points"]
    assert [
        (
            list(p.positions),
            list(p.velocities),
            list(p.accelerations),
            p.time_from_start.sec,
            p.time_from_start.nanosec,
        )
        for p in msg.points
    ] == [
        (
            p["positions"],
            p["velocities"],
            [],
            p["time_from_start"]["sec"],
            p["time_from_start"]["nanosec"],
        )
        for p in points
    ]


def _points(*points):
    return {"trajectory": {"joint_names": ["drs_piston"], "points": list(points)}}


@pytest.mark.parametrize(
    ("goal", "match"),
    [
        ({"goal": 1}, "no 'trajectory' mapping"),
        ({"trajectory": {"joint_names": [], "points": []}}, "joint_names must be a list of names"),
        (_points(), "the trajectory has no points"),
        (_points({"positions": [0.01, 0.02]}), r"point 0: positions must hold 1 value\(s\)"),
        (
            _points(
                {"positions": [0.01], "time_from_start": {"sec": 1}},
                {"positions": [float("nan")], "time_from_start": {"sec": 2}},
            ),
            "point 1: positions must be finite numbers",
        ),
        (
            _points(
                {"positions": [0.01], "time_from_start": {"sec": 1}},
                {"positions": [0.02], "time_from_start": {"sec": 1}},
            ),
            "point 1: time_from_start must increase",
        ),
        (
            _points({"positions": [0.01], "time_from_start": {"sec": 0, "nanosec": 2_000_000_000}}),
            r"point 0: time_from_start must be >= 0 s with nanosec in \[0, 1e9\)",
        ),
    ],
)
def test_a_malformed_goal_is_the_file_s_error_naming_the_point(tmp_path, goal, match):
    bag = tmp_path / "bag"
    status, out, err = drs_bag("from-goal", _goal(tmp_path, goal), "-o", bag)
    assert status == EXIT_UNREADABLE, out + err
    assert err.startswith("drs-bag from-goal: error: '") and "usage" not in err
    assert re.search(match, err), err
    assert not bag.exists()


def test_an_unreadable_goal_an_existing_output_and_a_bad_topic_are_refused(tmp_path):
    bag = tmp_path / "bag"
    status, _out, err = drs_bag("from-goal", tmp_path / "missing.yaml", "-o", bag)
    assert status == EXIT_UNREADABLE and "cannot read the goal" in err and not bag.exists()
    bag.mkdir()
    (bag / "keep.txt").write_text("mine")
    status, _out, err = drs_bag("from-goal", _goal(tmp_path), "-o", bag)
    assert status == EXIT_UNREADABLE and "exists: name a new bag directory" in err
    assert [p.name for p in bag.iterdir()] == ["keep.txt"]
    status, _out, err = drs_bag(
        "from-goal", _goal(tmp_path), "-o", tmp_path / "b", "--topic", "relative/name"
    )
    assert status == EXIT_USAGE and "argument --topic: needs an absolute topic name" in err
