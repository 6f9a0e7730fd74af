"""The committed example recording (bags/example, bags/example.rrd) stays readable by independent
readers and passes drs-check: a regression guard on the recording format."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from ros_support import require_rclpy

BAGS = Path(__file__).resolve().parent.parent / "bags"


def test_rosbags_reads_the_example_bag(params):
    require_rclpy()
    from rosbags.highlevel import AnyReader

    from drs_model.constraints import constraint

    with AnyReader([BAGS / "example"]) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        assert topics["/joint_states"] == "sensor_msgs/msg/JointState"
        assert topics["/drs/stroke_cmd"] == "std_msgs/msg/Float64"
        conns = [c for c in reader.connections if c.topic == "/joint_states"]
        q = np.array(
            [
                reader.deserialize(raw, c.msgtype).position
                for c, _, raw in reader.messages(connections=conns)
            ]
        )
    assert len(q) > 500
    assert np.abs(constraint(q, params)).max() < 1e-12
    from drs_model.kinematics import stroke_limits

    assert q[:, 0].max() == pytest.approx(stroke_limits(params)[1], abs=1e-12)  # opened fully


def test_drs_check_passes_on_the_example(capsys):
    require_rclpy()
    from drs_ros.bag.check.command import main

    assert main([str(BAGS / "example")]) == 0
    out = capsys.readouterr().out
    assert "loop constraint" in out
    # the force of the recorded motion is replayed exactly from the logged acceleration
    row = next(line for line in out.splitlines() if "logged accel." in line)
    assert row.split()[-1] != "skipped" and " ok" in row


def test_example_rrd_reads_back():
    require_rclpy()
    from rerun.chunk import RrdReader

    entities = set()
    for chunk in RrdReader(str(BAGS / "example.rrd")).stream().to_chunks():
        entities.add(str(chunk.entity_path))
    assert any("mechanism/flap" in e for e in entities)
    assert any("series/piston_force" in e for e in entities)


def test_rerun_verifies_the_example_rrd():
    """``rerun rrd verify`` (the SDK's own CLI) loads and interprets every chunk."""
    require_rclpy()
    from drs_ros.recording.rerun_cli import run_rerun_cli

    res = run_rerun_cli(["rrd", "verify", str(BAGS / "example.rrd")])
    assert res.returncode == 0, res.stderr[-2000:]
