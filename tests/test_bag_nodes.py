"""The bag names its node: a drs node run under any name, namespace and remapping, with model
parameters of its own, and its bag read by every drs-bag verb by the names it recorded
(drs_ros.bag.read.nodes); two nodes of one car recorded into one bag, picked with --node.

Each run is a real node process over loopback DDS, driven by a client in this process (a stroke
command, then the service opens and closes the flap). The runs are parametrized over the node's
launch arguments (:data:`LAUNCHES`) and its rung (:data:`RUNGS`), so that more of both give the
matrix of names x rungs x faults.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest
from bag_support import copy_bags, message_editor
from launch_support import REAR_NAMING, REAR_TOPICS, remap_args
from node_support import domain_for, node_env, spin_for, spin_until, wait_for_file_growth
from ros_support import require_rclpy

from drs_ros.node.command_line import node_command

pytestmark = pytest.mark.ros


@dataclass(frozen=True)
class Launch:
    """How a node is started (its ``--ros-args``), its fully qualified name, the topics of it
    the tests read (as they should be found), and the model mass [kg] of its flap."""

    ros_args: tuple[str, ...]
    node: str
    joint_states: str
    piston_force: str
    m_wing: float


#: Node names as a stack gives them: the default, and a namespace with a renamed node and its
#: remapped topics (an absolute one, the joint states, and private ones, the piston force read
#: here and the piston-side pressure, which the rigid rung does not publish).
LAUNCHES = {
    "default": Launch(
        ("-p", "model.m_wing:=3.0"), "/drs", "/joint_states", "/drs/piston_force", 3.0
    ),
    "renamed": Launch(
        (*remap_args(REAR_NAMING | REAR_TOPICS), "-p", "model.m_wing:=3.0"),
        "/car7/drs_rear",
        "/car7/joint_states",
        "/car7/rear_force",
        3.0,
    ),
}
#: The rungs the runs are made on.
RUNGS = ("rigid",)
#: Two actuators of one car in two namespaces, each with its own flap mass.
FRONT = Launch(
    (
        "-r",
        "__ns:=/car7/front",
        "-r",
        "__node:=drs_front",
        "-r",
        "/joint_states:=joint_states",
        "-p",
        "model.m_wing:=3.0",
    ),
    "/car7/front/drs_front",
    "/car7/front/joint_states",
    "/car7/front/drs_front/piston_force",
    3.0,
)
REAR = Launch(
    (
        "-r",
        "__ns:=/car7/rear",
        "-r",
        "__node:=drs_rear",
        "-r",
        "/joint_states:=joint_states",
        "-p",
        "model.m_wing:=2.5",
    ),
    "/car7/rear/drs_rear",
    "/car7/rear/joint_states",
    "/car7/rear/drs_rear/piston_force",
    2.5,
)


def drs_bag(*args) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
    )


def record_runs(out: Path, launches: list[tuple[Launch, str]], domain: int) -> list[Path]:
    """Start a node process per ``(launch, rung)`` (at once, each recording its own bag), drive
    each (stroke 30 mm, open, close through the service), stop them with SIGINT; their bags."""
    require_rclpy()
    procs, bags = [], []
    try:
        for i, (launch, rung) in enumerate(launches):
            bag = out / f"bag{i}"
            args = node_command(
                {"fidelity": rung, "bag_path": bag, "flush_period": 0.2}, ros_args=launch.ros_args
            )
            procs.append(
                subprocess.Popen(
                    args,
                    env=node_env(out, domain),
                    text=True,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.STDOUT,
                )
            )
            bags.append(bag)
        for bag in bags:
            assert wait_for_file_growth(bag / f"{bag.name}_0.mcap", timeout=60.0), "no bag"
        drive([launch for launch, _ in launches], domain, out)
        for proc in procs:
            proc.send_signal(signal.SIGINT)
        for proc in procs:
            log, _ = proc.communicate(timeout=60)
            assert proc.returncode == 0, log[-3000:]
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    return bags


@contextmanager
def client_node(name: str, domain: int, out: Path):
    """An rclpy node of this process in ``domain`` (loopback only) and its executor."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    mp = pytest.MonkeyPatch()
    mp.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    mp.setenv("ROS_LOG_DIR", str(out / "ros-log"))
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node(name, context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        yield node, ex
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        mp.undo()


def drive(launches: list[Launch], domain: int, out: Path) -> None:
    """Command each node by its names, once its joint states flow: a stroke of 30 mm, held
    (off the end stops: the force is judged there), then open and close through the service."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64
    from std_srvs.srv import SetBool

    with client_node("drs_bag_nodes_client", domain, out) as (client, ex):
        strokes = {}
        for launch in launches:
            strokes[launch.node] = seen = []
            client.create_subscription(
                JointState,
                launch.joint_states,
                lambda m, seen=seen: seen.append(m.position[0]),
                100,
            )
        stroke_cmds = [
            client.create_publisher(Float64, f"{x.node}/stroke_cmd", 10) for x in launches
        ]
        services = [client.create_client(SetBool, f"{x.node}/drs") for x in launches]
        for service in services:
            assert service.wait_for_service(timeout_sec=60.0), service.srv_name
        assert spin_until(ex, lambda: all(len(v) > 5 for v in strokes.values()), 30.0)
        for stroke in stroke_cmds:
            assert spin_until(ex, lambda s=stroke: s.get_subscription_count() > 0, 30.0)
            stroke.publish(Float64(data=0.03))
        held = lambda: all(abs(v[-1] - 0.03) < 1e-6 for v in strokes.values())  # noqa: E731
        assert spin_until(ex, held, 10.0), {k: v[-1] for k, v in strokes.items()}
        spin_for(ex, 0.4)
        for value in (True, False):
            futures = [s.call_async(SetBool.Request(data=value)) for s in services]
            assert spin_until(ex, lambda fs=futures: all(f.done() for f in fs), 10.0)
            assert all(f.result().success for f in futures)
            spin_for(ex, 0.4)


RUNS = [(name, rung) for name in LAUNCHES for rung in RUNGS]


@pytest.fixture(scope="module", params=RUNS, ids=[f"{n}-{r}" for n, r in RUNS])
def run(request, tmp_path_factory):
    """A node's recorded run: ``(launch, bag)``."""
    name, rung = request.param
    out = tmp_path_factory.mktemp(f"{name}-{rung}")
    launch = LAUNCHES[name]
    (bag,) = record_runs(out, [(launch, rung)], domain_for(f"test_bag_nodes::{name}-{rung}"))
    return launch, bag


def check_json(*args) -> tuple[int, dict]:
    res = drs_bag("check", *args, "--json")
    assert res.returncode in (0, 1), res.stdout + res.stderr
    return res.returncode, json.loads(res.stdout)


def force_check(report: dict) -> dict:
    (found,) = [c for c in report["checks"] if c["name"] == "piston force vs model, logged accel."]
    return found


def test_check_judges_the_run_with_the_parameters_it_recorded(run):
    launch, bag = run
    status, report = check_json(bag)
    assert status == 0, report
    assert report["node"] == launch.node
    assert f"model parameters: recorded by {launch.node} on /parameter_events" in report["notes"]
    assert f"node: {launch.node} (topics from its topics record)" in report["notes"]
    loop = next(c for c in report["checks"] if c["name"] == "loop constraint |Phi(q)|")
    assert loop["topic"] == launch.joint_states and loop["samples"] > 100
    force = force_check(report)
    assert force["status"] == "ok" and force["samples"] > 50  # the moves were judged
    assert report["messages"][launch.piston_force] == report["messages"][launch.joint_states]


def test_a_changed_force_fails_check(run, tmp_path):
    """One joint state's piston effort, in mid-stroke, 50 N off: FAIL on the force."""
    launch, bag = run
    from decoded_support import read_bag

    states = read_bag(bag, [launch.joint_states]).messages[launch.joint_states]
    strokes = [m.position[0] for _, m in states]
    middle = (max(strokes) + min(strokes)) / 2
    target = min(range(len(states)), key=lambda i: abs(strokes[i] - middle))
    seen = [0]

    def edit(msg) -> bool:
        seen[0] += 1
        if seen[0] - 1 != target:
            return False
        msg.effort = [msg.effort[0] + 50.0, *msg.effort[1:]]
        return True

    tampered = copy_bags(
        [bag],
        tmp_path / "tampered",
        message_editor("sensor_msgs/msg/JointState", edit, launch.joint_states),
    )
    assert seen[0] == len(states)
    status, report = check_json(tampered)
    assert status == 1
    force = force_check(report)
    assert force["status"] == "FAIL" and force["max_error"] == pytest.approx(50.0, abs=1e-6)


def test_a_changed_recorded_parameter_fails_check(run, tmp_path):
    """m_wing in the recorded parameter event put back to the seed's 2.0 kg: the recorded
    forces (of a 3 kg flap) fail against it; the untouched copy passes."""
    launch, bag = run
    from drs_model.params import DRSParams

    assert DRSParams().m_wing != launch.m_wing

    def edit(event) -> bool:
        for p in event.new_parameters:
            if p.name == "model.m_wing":
                p.value.double_value = DRSParams().m_wing
        return True

    tampered = copy_bags(
        [bag], tmp_path / "tampered", message_editor("rcl_interfaces/msg/ParameterEvent", edit)
    )
    status, report = check_json(tampered)
    assert status == 1 and force_check(report)["status"] == "FAIL"
    assert check_json(copy_bags([bag], tmp_path / "copy"))[0] == 0  # the copy alone passes


def assert_re_runs_exactly(bag: Path, node: str, *args) -> None:
    """``drs-bag resimulate BAG ARGS``: the run of ``node``, every signal to the last bit."""
    res = drs_bag("resimulate", bag, *args, "--json")
    assert res.returncode == 0, res.stdout + res.stderr
    report = json.loads(res.stdout)
    assert report["node"] == node
    assert all(r["max_deviation"] == 0.0 and r["samples"] > 100 for r in report["signals"])


def test_resimulate_re_runs_it_exactly(run):
    launch, bag = run
    assert_re_runs_exactly(bag, launch.node)


def test_info_index_and_fleet_name_the_node_and_its_topics(run, tmp_path):
    import pyarrow.parquet as pq

    launch, bag = run
    res = drs_bag("info", bag, "--json")
    assert res.returncode == 0, res.stderr
    (node,) = json.loads(res.stdout)["nodes"]
    assert node["name"] == launch.node and node["topics_from"] == "its topics record"
    assert node["topics"]["joint_states"] == launch.joint_states
    assert node["topics"]["piston_force"] == launch.piston_force
    assert node["topics"]["stroke_cmd"] == f"{launch.node}/stroke_cmd"
    text = drs_bag("info", bag).stdout
    assert "DRS nodes:         1" in text
    assert f"piston_force             {launch.piston_force}" in text
    res = drs_bag("index", bag.parent, "-o", tmp_path / "catalogue.parquet")
    assert res.returncode == 0, res.stderr
    (row,) = pq.read_table(tmp_path / "catalogue.parquet").to_pylist()
    assert row["nodes"] == [launch.node]
    res = drs_bag("check", bag, "--jobs", "1", "-o", tmp_path / "table.parquet")
    assert res.returncode == 0, res.stdout + res.stderr
    (row,) = pq.read_table(tmp_path / "table.parquet").to_pylist()
    assert (row["node"], row["verdict"], row["param_m_wing"]) == (launch.node, "PASS", 3.0)
    assert row["peak_force_n"] > 1000.0 and row["largest_gap_m"] > 0.04


def test_an_unfinished_recording_names_its_node_too(run, tmp_path):
    """A recording cut short (no summary, no metadata.yaml): info finds its node by reading the
    file from its start, and recover's report names it with its topics."""
    launch, bag = run
    cut = tmp_path / "cut"
    cut.mkdir()
    data = next(bag.glob("*.mcap")).read_bytes()
    (cut / "cut_0.mcap").write_bytes(data[: int(len(data) * 0.6)])
    res = drs_bag("info", cut, "--json")
    assert res.returncode == 0, res.stderr
    (node,) = json.loads(res.stdout)["nodes"]
    assert (node["name"], node["topics"]["piston_force"]) == (launch.node, launch.piston_force)
    res = drs_bag("recover", cut, "-o", tmp_path / "whole", "--json")
    assert res.returncode == 3, res.stderr
    (node,) = json.loads(res.stdout)["nodes"]
    assert (node["name"], node["topics"]["joint_states"]) == (launch.node, launch.joint_states)


def test_an_older_bag_names_its_node_by_its_parameters_alone(tmp_path):
    """The example predates the topics record: its node is /drs by its parameter event, its
    topics those /drs has unremapped. Its joint states moved (as a remapping would have put
    them) cannot be seen from the bag: check says which topic it lacks and which option names
    it, and judges them with that option."""
    require_rclpy()
    example = Path(__file__).resolve().parents[1] / "bags" / "example"
    status, report = check_json(example)
    assert status == 0 and report["node"] == "/drs"
    assert (
        "node: /drs (topics from its name, unremapped: the bag records no topic names)"
        in report["notes"]
    )
    moved = copy_bags([example], tmp_path / "moved", rename={"/joint_states": "/car7/joint_states"})
    _status, report = check_json(moved)
    assert (
        "the bag holds no /joint_states (joint_states of /drs unremapped): if it was "
        "remapped, name it with --joint-states-topic"
    ) in report["notes"]
    status, report = check_json(moved, "--joint-states-topic", "/car7/joint_states")
    assert status == 0 and force_check(report)["samples"] > 100
    assert {c["topic"] for c in report["checks"]} >= {"/car7/joint_states"}


# ---- two drs nodes in one bag ----------------------------------------------------------------
@pytest.fixture(scope="module")
def car(tmp_path_factory):
    """Two actuators of one car, run at once, each recording its own bag, merged into one bag
    (``car/both``); also returns the two bags."""
    out = tmp_path_factory.mktemp("car")
    bags = record_runs(out, [(FRONT, "rigid"), (REAR, "rigid")], domain_for("test_bag_nodes::car"))
    (out / "car").mkdir()
    res = drs_bag("merge", *bags, "-o", out / "car" / "both")
    assert res.returncode == 0, res.stdout + res.stderr
    return out / "car" / "both", bags


def test_a_bag_of_two_nodes_asks_which(car):
    both, _ = car
    for verb in ("check", "resimulate"):
        res = drs_bag(verb, both)
        assert res.returncode == 2, res.stdout + res.stderr
        assert "--node NAME" in res.stderr and FRONT.node in res.stderr and REAR.node in res.stderr
    res = drs_bag("check", both, "--node", "/car7/drs_rear")
    assert res.returncode == 2 and "--node '/car7/drs_rear' names none" in res.stderr


def test_the_merged_bag_holds_every_record_of_both_as_recorded(car):
    """``drs-bag merge``: every message of each bag with its bytes, times and sequence, in the
    order its bag recorded it (the bags interleaved by log time); a topic both bags hold
    (/parameter_events, /diagnostics, ...) is one channel; metadata.yaml counts them; rosbags
    and mcap_ros2 read every message."""
    from test_bag_tools import judge_with_mcap_ros2, judge_with_rosbags

    from drs_ros.bag.read.files import read_metadata
    from drs_ros.bag.read.reader import scan

    both, bags = car

    def records(bag):
        out = []
        result = scan(
            bag, lambda m: out.append((m.topic, m.log_time, m.publish_time, m.sequence, m.data))
        )
        return out, result

    merged, result = records(both)
    sources = [records(bag)[0] for bag in bags]
    assert sorted(merged) == sorted(sources[0] + sources[1])
    for source in sources:  # each bag's records in its own order
        mine = set(source)
        assert [r for r in merged if r in mine] == source
    topics = [c.topic for c in result.channels.values()]
    assert len(topics) == len(set(topics)) and "/parameter_events" in topics
    meta = read_metadata(both / "metadata.yaml")
    assert meta["message_count"] == len(merged) and meta["storage_identifier"] == "mcap"
    counts = judge_with_rosbags(both)
    assert counts == judge_with_mcap_ros2(both) == {t: n for t, n in result.counts.items() if n}


@pytest.mark.parametrize("launch", [FRONT, REAR], ids=["front", "rear"])
def test_each_node_of_the_bag_checks_and_re_runs_exactly(car, launch):
    both, _ = car
    status, report = check_json(both, "--node", launch.node)
    assert status == 0, report
    assert report["node"] == launch.node
    assert f"model parameters: recorded by {launch.node} on /parameter_events" in report["notes"]
    assert {c["topic"] for c in report["checks"]} >= {launch.joint_states}
    assert force_check(report)["samples"] > 50
    short = launch.node.rsplit("/", 1)[-1]  # its own name picks it too
    assert_re_runs_exactly(both, launch.node, "--node", short)


def test_the_fleet_gives_a_row_per_node(car, tmp_path):
    import pyarrow.parquet as pq

    both, _ = car
    res = drs_bag("check", both.parent, "--jobs", "1", "-o", tmp_path / "table.parquet")
    assert res.returncode == 0, res.stdout + res.stderr
    rows = pq.read_table(tmp_path / "table.parquet").to_pylist()
    assert [(r["bag"], r["node"], r["verdict"]) for r in rows] == [
        (str(both), FRONT.node, "PASS"),
        (str(both), REAR.node, "PASS"),
    ]
    assert [r["param_m_wing"] for r in rows] == [FRONT.m_wing, REAR.m_wing]
    assert "1 bags, 2 rows: 2 PASS" in res.stdout
    res = drs_bag(
        "resimulate",
        both.parent,
        "--jobs",
        "1",
        "--node",
        REAR.node,
        "-o",
        tmp_path / "rerun.parquet",
    )
    assert res.returncode == 0, res.stdout + res.stderr
    (row,) = pq.read_table(tmp_path / "rerun.parquet").to_pylist()
    assert (row["node"], row["verdict"], row["stroke_deviation_m"]) == (REAR.node, "PASS", 0.0)


def test_play_plays_the_topics_of_the_node_named(car, tmp_path):
    """``drs-bag play --node`` with ``--topics`` naming both actuators' forces: the front
    actuator's force on its topic, none of the rear's."""
    from std_msgs.msg import Float64

    both, _ = car
    domain = domain_for("test_bag_nodes::play")
    got = {FRONT.piston_force: [], REAR.piston_force: []}
    with client_node("drs_play_listener", domain, tmp_path) as (listener, ex):
        for topic, seen in got.items():
            listener.create_subscription(Float64, topic, seen.append, 1000)
        player = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "drs_ros.bag.cli",
                "play",
                str(both),
                "--node",
                FRONT.node,
                "--topics",
                FRONT.piston_force,
                REAR.piston_force,
                "--wait-for-subscribers",
                "--rate",
                "4",
            ],
            env=node_env(tmp_path, domain),
            text=True,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
        )
        try:
            end = time.monotonic() + 120
            while player.poll() is None and time.monotonic() < end:
                spin_for(ex, 0.1)
            spin_for(ex, 0.5)
            log, _ = player.communicate(timeout=30)
        finally:
            if player.poll() is None:
                player.kill()
                player.communicate()
    assert player.returncode == 0, log
    from decoded_support import read_bag

    recorded = read_bag(both, [FRONT.piston_force]).messages[FRONT.piston_force]
    assert len(got[FRONT.piston_force]) > len(recorded) / 2 and got[REAR.piston_force] == []


def test_fit_fits_the_run_of_the_node_named_and_a_season_gives_a_row_per_node(car, tmp_path):
    """Each actuator's flap mass, fitted from its own topics (``--node``), is the mass it
    recorded (3.0 kg front, 2.5 kg rear: the other's would be off by 0.5 kg); a season over the
    bag has one row per node, with the node column."""
    import pyarrow.parquet as pq

    both, _ = car
    fit = ("fit", "--params", "m_wing", "--stage", "equation")
    res = drs_bag(*fit[:1], both, *fit[1:])
    assert res.returncode == 2, res.stdout + res.stderr
    assert "--node NAME" in res.stderr and FRONT.node in res.stderr and REAR.node in res.stderr
    for launch in (FRONT, REAR):
        res = drs_bag(*fit[:1], both, *fit[1:], "--node", launch.node, "--json")
        assert res.returncode == 0, res.stdout + res.stderr
        doc = json.loads(res.stdout)
        assert doc["node"] == launch.node and doc["topics"]["joint_states"] == launch.joint_states
        (m_wing,) = doc["estimates"]
        # the node's states are its model's, noise-free: the fit is the recorded mass
        assert m_wing["determined"] and m_wing["value"] == pytest.approx(launch.m_wing, abs=1e-6)
    res = drs_bag(*fit[:1], both.parent, *fit[1:], "--jobs", "1", "-o", tmp_path / "season.parquet")
    assert res.returncode == 0, res.stdout + res.stderr
    rows = pq.read_table(tmp_path / "season.parquet").to_pylist()
    assert [(r["bag"], r["node"], r["verdict"]) for r in rows] == [
        (str(both), FRONT.node, "FITTED"),
        (str(both), REAR.node, "FITTED"),
    ]
    assert [r["m_wing"] for r in rows] == pytest.approx([FRONT.m_wing, REAR.m_wing], abs=1e-6)
    assert [r["param_m_wing"] for r in rows] == [FRONT.m_wing, REAR.m_wing]
