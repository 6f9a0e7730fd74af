"""``drs-bag fit`` of a bag another tool wrote: a JointState-only MCAP written by mcap_ros2's
writer (exact values of a 2.0 kg wing through the opening and closing, efforts the piston
force). The acceleration is differentiated from the joint states: the report says so and what
it left out, and the interval, paying for the derivative's error, holds 2.0 kg."""

from __future__ import annotations

import json

import pytest
from identify_support import run_rung
from test_bag_fit import drs_bag

from drs_model.params import DRSParams


def _write_joint_states(path, table) -> None:
    from mcap_ros2.writer import Writer

    from drs_ros.recording import msgdefs

    with open(path, "wb") as f:
        writer = Writer(f)
        name = "sensor_msgs/msg/JointState"
        schema = writer.register_msgdef(name, msgdefs.full_definition(name))
        for k, (t, s, sd, _, force, *_) in enumerate(table):
            ns = 10**9 + round(t * 1e9)
            msg = {
                "header": {"stamp": {"sec": ns // 10**9, "nanosec": ns % 10**9}, "frame_id": ""},
                "name": ["piston"],
                "position": [s],
                "velocity": [sd],
                "effort": [force],
            }
            writer.write_message(
                "/joint_states", schema, msg, log_time=ns, publish_time=ns, sequence=k
            )
        writer.finish()


@pytest.mark.parametrize("dt", [1e-3, 5e-4])
def test_a_joint_state_only_mcap_fits_the_wing_within_its_interval(tmp_path, dt):
    p = DRSParams()
    table = run_rung(
        "rigid", p, moves=((0, True), (int(0.04 / dt), False)), steps=int(0.08 / dt), dt=dt
    )
    bag = tmp_path / "joint_states.mcap"
    _write_joint_states(bag, table)
    res = drs_bag(
        "fit", bag, "--fidelity", "rigid", "--params", "m_wing", "--joint", "piston", "--json"
    )
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    (e,) = doc["estimates"]
    assert e["lower"] <= p.m_wing <= e["upper"], e
    assert 0.0 < e["lower"] < e["upper"]
    notes = " ".join(doc["stages"][0]["notes"])
    assert "stroke_acceleration not recorded: Savitzky-Golay derivative" in notes
    assert "end-stop contact" in notes and "derivative window" in notes
