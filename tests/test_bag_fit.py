"""``drs-bag fit``: a bag whose truth is known (recorded as the node records it, with faults and
seeded stroke noise) fits to its truth within the intervals; the bag re-runs exactly (it is a
bag the node would write); a rosbags-written bag of JointState and FluidPressure fits like the
drs one; what a run cannot determine is reported, with the exit status that says so."""

from __future__ import annotations

import contextlib
import io
import json
import subprocess

import numpy as np
import pytest
from launch_support import REAR_NAMING, REAR_TOPICS, remap_args
from ros_support import require_rclpy

from drs_model.params import DRSParams

HYDRAULIC_FAULTS = {
    "leak_m3_per_s_per_pa": 2e-13,
    "jam_friction_n": 30.0,
    "sensor.noise_std_m": 1e-5,
    "sensor.noise_seed": 3,
}
#: The truth of the hydraulic bag: HydraulicParams' defaults plus the faults.
TRUTH = {"leak_to_outside": 2e-13, "coulomb_friction": 70.0, "breakaway_friction": 90.0}


def drs_bag(*args) -> subprocess.CompletedProcess:
    """``drs-bag ARGS`` in this process (its imports and compiled kernels are warm here)."""
    from drs_ros.bag.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main([str(a) for a in args])
        except SystemExit as exc:  # argparse's usage error
            status = exc.code
    return subprocess.CompletedProcess(args, status, out.getvalue(), err.getvalue())


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    require_rclpy()
    from run_support import Command, record_run, seed_commands

    out = tmp_path_factory.mktemp("fit")
    p = DRSParams()
    hydraulic = record_run(
        out / "hydraulic",
        130,
        [Command(1, "drs", True), Command(70, "drs", False)],
        fidelity="hydraulic",
        faults=HYDRAULIC_FAULTS,
    )
    rigid = record_run(
        out / "rigid",
        80,
        seed_commands(p),
        fidelity="rigid",
        faults={"sensor.noise_std_m": 1e-5, "sensor.noise_seed": 1},
    )
    return {"hydraulic": hydraulic, "rigid": rigid, "dir": out}


def test_a_recorded_run_re_runs_exactly(bags):
    """What says these bags are what the node records: drs-bag resimulate re-runs them to the
    bit, the faults given at start included (the stroke's noise of the very first sample)."""
    res = drs_bag("resimulate", str(bags["hydraulic"]), "--json")
    assert res.returncode == 0, res.stdout + res.stderr
    assert all(r["max_deviation"] == 0.0 for r in json.loads(res.stdout)["signals"])


def test_a_leak_and_a_jam_are_recovered_within_their_intervals(bags, tmp_path):
    out, png = tmp_path / "fit.json", tmp_path / "fit.png"
    res = drs_bag(
        "fit",
        str(bags["hydraulic"]),
        "--params",
        ",".join(TRUTH),
        "--json",
        "-o",
        str(out),
        "--plot",
        str(png),
    )
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert json.loads(out.read_text()) == doc
    assert doc["rung"] == "hydraulic"
    for e in doc["estimates"]:
        assert e["stage"] == "output" and e["determined"], e
        assert e["lower"] <= TRUTH[e["name"]] <= e["upper"], e
    assert [s["stage"] for s in doc["stages"]] == ["equation", "equation", "output"]
    import matplotlib.image

    image = matplotlib.image.imread(png)
    assert image.shape[0] > 400 and image.shape[1] > 600


def test_what_the_run_cannot_separate_is_refused_with_its_reason(bags):
    """The five inertial parameters: the link's mass acts as point masses at its pins, and
    only gravity (at a 10 um stroke noise) tells it apart: four intervals wider than their
    values, reported as not determined with what they trade off with."""
    res = drs_bag(
        "fit",
        str(bags["rigid"]),
        "--params",
        "m_pist,m_link,m_wing,Iz_link,Iz_wing",
        "--stage",
        "equation",
    )
    assert res.returncode == 1, res.stderr
    assert "not determined (no value reported):" in res.stdout
    assert res.stdout.count("the data do not determine it; it trades off with") >= 3
    assert "trade off: m_pist and m_link" in res.stdout
    assert "to determine it: accelerate the rod" in res.stdout


def _rewrite_with_rosbags(src, dst):
    """The drs bag's joint states (piston only, named 'piston'), chamber and supply pressures
    and spool, written by rosbags' own writer and type store on other topics."""
    from decoded_support import read_bag
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from drs_ros.bag.season.measured import measured_topics

    drs_topics = measured_topics(None)  # a node of the default name, by role
    ts = get_typestore(Stores.ROS2_JAZZY)
    T = ts.types
    data = read_bag(src, list(drs_topics.values()))
    topics = {
        "joint_states": "/actuator/joint_states",
        "pressure_a": "/hyd/cap_end",
        "pressure_b": "/hyd/rod_end",
        "supply_pressure": "/hyd/supply",
        "spool": "/hyd/spool",
    }
    kinds = {"joint_states": "sensor_msgs/msg/JointState", "spool": "std_msgs/msg/Float64"}
    with Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for role, topic in topics.items():
            kind = kinds.get(role, "sensor_msgs/msg/FluidPressure")
            conn = w.add_connection(topic, kind, typestore=ts)
            for log, m in data.messages[drs_topics[role]]:
                if role == "spool":
                    msg = T[kind](data=m.data)
                else:
                    header = T["std_msgs/msg/Header"](
                        stamp=T["builtin_interfaces/msg/Time"](
                            sec=m.header.stamp.sec, nanosec=m.header.stamp.nanosec
                        ),
                        frame_id="",
                    )
                    if role == "joint_states":
                        msg = T[kind](
                            header=header,
                            name=["piston"],
                            position=np.array(m.position[:1]),
                            velocity=np.array(m.velocity[:1]),
                            effort=np.array(m.effort[:1]),
                        )
                    else:
                        msg = T[kind](header=header, fluid_pressure=m.fluid_pressure, variance=0.0)
                w.write(conn, log, ts.serialize_cdr(msg, kind))
    return dst, topics


def test_a_rosbags_written_bag_fits_like_the_drs_one(bags, tmp_path):
    foreign, topics = _rewrite_with_rosbags(bags["hydraulic"], tmp_path / "foreign")
    names = "leak_to_outside,valve_rated_flow,coulomb_friction,viscous_friction"
    mapping = ",".join(f"{k}={v}" for k, v in topics.items())
    res = drs_bag(
        "fit", str(foreign), "--params", names, "--topic-map", mapping, "--joint", "piston"
    )
    assert (
        res.returncode == 2
        and "error: --fidelity: the bag does not say which rung it ran on" in res.stderr
    )
    res = drs_bag(
        "fit",
        str(foreign),
        "--params",
        names,
        "--topic-map",
        mapping,
        "--joint",
        "piston",
        "--fidelity",
        "hydraulic",
        "--json",
    )
    assert res.returncode == 0, res.stderr
    got = json.loads(res.stdout)
    assert "no clock records" in " ".join(got["notes"])
    assert got["node"] is None and got["topics"]["pressure_a"] == "/hyd/cap_end"
    ref = json.loads(
        drs_bag(
            "fit", str(bags["hydraulic"]), "--params", names, "--stage", "equation", "--json"
        ).stdout
    )
    for a, b in zip(got["estimates"], ref["estimates"], strict=True):
        assert a["stage"] == "equation"  # no commands recorded: no output error
        for key in ("value", "lower", "upper"):
            assert a[key] == pytest.approx(b[key], rel=1e-9), (a, b)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (
            ["--params", "leak_to_outside"],
            "the model refuses the fit: the 'rigid' rung has no hydraulics",
        ),
        (["--params", "m_pist", "--set", "m_wing=-1"], "the model refuses the fit: "),
        (["--params", "m_pist", "-o", "fit.csv"], "-o names the report"),
    ],
)
def test_what_the_bag_s_model_cannot_fit_is_refused_with_a_reason(bags, args, match):
    res = drs_bag("fit", str(bags["rigid"]), *args)
    assert res.returncode == 2 and match in res.stderr, res.stderr
    assert "usage:" not in res.stderr


def test_a_bag_without_the_joint_states_named_is_refused(bags):
    res = drs_bag(
        "fit", str(bags["rigid"]), "--params", "m_pist", "--topic-map", "joint_states=/nothing/here"
    )
    assert res.returncode == 2 and "no joint states on /nothing/here" in res.stderr
    res = drs_bag(
        "fit",
        str(bags["rigid"]),
        "--params",
        "m_pist",
        "--topic-map",
        "joint_states=/drs/piston_force",
    )
    assert res.returncode == 2, res.stderr
    assert (
        "/drs/piston_force holds std_msgs/msg/Float64 messages; the role joint_states needs "
        "sensor_msgs/msg/JointState"
    ) in res.stderr


#: The node as a stack names it: in a namespace, renamed, its joint states, piston force and
#: piston-side pressure remapped (``(namespace, --ros-args, node, joint states, pressure_a)``).
NODE_NAMES = {
    "default": (None, [], "/drs", "/joint_states", "/drs/pressure_piston_side"),
    "renamed": (
        REAR_NAMING["__ns"],
        remap_args({"__node": REAR_NAMING["__node"], **REAR_TOPICS}),
        "/car7/drs_rear",
        "/car7/joint_states",
        "/car7/rear_pressure_a",
    ),
}


@pytest.mark.ros
@pytest.mark.parametrize("naming", sorted(NODE_NAMES))
def test_a_node_bag_with_faults_given_at_start_re_runs_and_fits(ros_context, tmp_path, naming):
    """The node itself, hydraulic, started with a leak and a noisy stroke sensor
    (``-p fault.*:=...``), opened and closed through its service, under its default name and as
    a stack names it: its bag re-runs to the bit (the first state is published after the
    start's faults act, as the re-run now has it) and the fit finds the node by the name it
    recorded, reads its remapped topics, and finds the leak within its interval."""
    from node_support import spin_for, spin_until
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from std_srvs.srv import SetBool

    from drs_ros.node import DRSNode

    namespace, ros_args, name, joint_states, pressure_a = NODE_NAMES[naming]
    overrides = [
        Parameter("fidelity", value="hydraulic"),
        Parameter("publish_rate_hz", value=1000.0),
        Parameter("bag_path", value=str(tmp_path / "bag")),
        Parameter("fault.leak_m3_per_s_per_pa", value=2e-13),
        Parameter("fault.sensor.noise_std_m", value=1e-5),
        Parameter("fault.sensor.noise_seed", value=5),
    ]
    naming_args = {"cli_args": ["--ros-args", *ros_args]} if ros_args else {}
    if namespace:
        naming_args["namespace"] = namespace
    node = DRSNode(context=ros_context, parameter_overrides=overrides, **naming_args)
    assert node.get_fully_qualified_name() == name
    client = node.create_client(SetBool, f"{name}/drs")
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    try:
        assert client.wait_for_service(timeout_sec=10.0)
        for value in (True, False):
            fut = client.call_async(SetBool.Request(data=value))
            assert spin_until(ex, fut.done, 5.0) and fut.result().success
            spin_for(ex, 0.12)
    finally:
        node.close_recordings()
        ex.shutdown()
        node.destroy_node()
    res = drs_bag("resimulate", str(tmp_path / "bag"), "--json")
    assert res.returncode == 0, res.stdout + res.stderr
    res = drs_bag("fit", str(tmp_path / "bag"), "--params", "leak_to_outside", "--json")
    assert res.returncode == 0, res.stdout + res.stderr
    doc = json.loads(res.stdout)
    assert (
        doc["node"] == name
        and doc["model_parameters"] == f"recorded by {name} on /parameter_events"
    )
    assert (doc["topics"]["joint_states"], doc["topics"]["pressure_a"]) == (
        joint_states,
        pressure_a,
    )
    (leak,) = doc["estimates"]
    assert leak["stage"] == "output" and leak["lower"] <= 2e-13 <= leak["upper"], leak
    residuals = {r["signal"]: r for r in doc["stages"][-1]["residuals"]}
    assert residuals["pressure_a"]["samples"] > 20  # the remapped pressure was read and fitted


def test_a_node_bag_says_whether_a_stop_may_have_held_the_rod(bags, tmp_path):
    """The service's opening and closing only move the rod to its stops: the record says no
    stop held it; a run with a force command onto the open stop says one may have, and the
    rigid regression leaves those samples out (its notes count them)."""
    from run_support import Command, record_run

    from drs_ros.bag.read.nodes import bag_nodes
    from drs_ros.bag.season.measured import read_measured

    def measured(bag):
        (node,) = bag_nodes(bag)
        return read_measured(bag, node).record

    assert measured(bags["rigid"]).stops_hold is False
    forced = record_run(
        tmp_path / "forced", 80, [Command(1, "force_cmd", 1500.0)], fidelity="rigid"
    )
    assert measured(forced).stops_hold is True
    res = drs_bag("fit", forced, "--params", "m_wing", "--stage", "equation", "--json")
    notes = " ".join(json.loads(res.stdout)["stages"][0]["notes"])
    assert "end-stop contact" in notes, notes


def test_a_run_that_lost_its_supply_fits_the_leak_and_jam_it_had(tmp_path):
    """A hydraulic run with a leak and a jam from the start, 10 um of stroke noise, whose
    supply is lost 30 ms into the hold (over a 5 ms ramp: the servo commanded closed, the air
    load closes the flap) and back 30 ms later: the fit's re-run replays the supply loss (no
    parameter describes it) and leaves out the leak, the jam and the sensor's noise (what it
    estimates, and the record's own noise). Each estimate holds its truth, and the stroke's
    residual is the sensor's noise (within 20 %). Before, the re-run left every fault out and
    its flap stayed open through the loss."""
    require_rclpy()
    from run_support import Command, record_run

    bag = record_run(
        tmp_path / "supply_loss",
        150,
        [
            Command(1, "drs", True),
            Command(40, "fault", ("supply_loss_ramp_s", 0.005)),
            Command(40, "fault", ("supply_loss", True)),
            Command(70, "fault", ("supply_loss", False)),
            Command(100, "drs", True),
        ],
        fidelity="hydraulic",
        faults=HYDRAULIC_FAULTS,
    )
    res = drs_bag("fit", str(bag), "--params", ",".join(TRUTH), "--json")
    assert res.returncode == 0, res.stdout + res.stderr
    doc = json.loads(res.stdout)
    for e in doc["estimates"]:
        assert e["determined"] and e["lower"] <= TRUTH[e["name"]] <= e["upper"], e
    (stage,) = [s for s in doc["stages"] if s["stage"] == "output"]
    (stroke,) = [s for s in stage["residuals"] if s["signal"] == "stroke"]
    assert stroke["residual_rms"] == pytest.approx(HYDRAULIC_FAULTS["sensor.noise_std_m"], rel=0.2)
