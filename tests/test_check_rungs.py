"""``drs-bag check`` judges a run against the model that ran it: the rung the node recorded and
the faults set through its parameter service. The matrix: every rung, healthy and faulted, from
a real node process (started with launch arguments as a user would start it). Each bag passes
check, re-simulates with zero deviation, and a copy with one recorded value changed (a valid bag,
exact CDR) fails the check that must catch it."""

from __future__ import annotations

import contextlib
import io
import json
import math
import signal
import subprocess

import pytest
from launch_support import REAR_NAMING, REAR_TOPICS, remap_args
from node_support import call_answered, domain_for, node_env, spin_for, spin_until
from ros_support import require_rclpy, tampered_copy

pytestmark = pytest.mark.ros

require_rclpy()

from rclpy.parameter import Parameter  # noqa: E402

from drs_ros.node.command_line import node_command  # noqa: E402

#: The node's launch arguments (extra ``--ros-args`` items): its name, namespace, remappings.
#: ``renamed`` is a node named as a vehicle stack names it: a namespace, another node name, an
#: absolute and a private topic remapped, and a model parameter of its own.
LAUNCHES = {
    "default": [],
    "renamed": [*remap_args(REAR_NAMING | REAR_TOPICS), "-p", "model.m_wing:=3.0"],
}

RUNGS = ("kinematic", "quasi-static", "rigid", "hydraulic")


def _p(name: str, value) -> Parameter:
    return Parameter(f"fault.{name}", value=value)


SENSOR = [_p("sensor.bias_m", 1e-3), _p("sensor.noise_std_m", 1e-4), _p("sensor.noise_seed", 7)]
#: What a run does, one step every STEP_S: "open" and "close" through the service, "slow" a
#: trajectory to mid-stroke over SLOW_S (a move the node publishes many states of, however
#: loaded the machine), or a list of fault parameters set in one call through the parameter
#: service.
SCRIPTS = {
    ("kinematic", "healthy"): ["open", "slow", "close"],
    ("kinematic", "faulted"): [
        "open",
        SENSOR,
        [_p("sensor.dropout", 0.3)],
        "close",
        [_p("sensor.frozen", True)],
    ],
    ("quasi-static", "faulted"): [
        "open",
        SENSOR,
        [_p("sensor.dropout", 0.3)],
        [_p("sensor.frozen", True)],
        [_p("supply_loss", True)],
    ],
    ("hydraulic", "faulted"): [
        "open",
        [_p("leak_m3_per_s_per_pa", 2e-12)],
        [_p("stuck_valve", True)],
        [_p("stuck_valve", False)],
        [_p("jam_friction_n", 100.0)],
        SENSOR,
        [_p("sensor.dropout", 0.3)],
        [_p("supply_loss_ramp_s", 0.05), _p("supply_loss", True)],
    ],
}
SCRIPTS[("quasi-static", "healthy")] = SCRIPTS[("rigid", "healthy")] = ["open", "slow", "close"]
SCRIPTS[("hydraulic", "healthy")] = ["open", "slow", "close"]
SCRIPTS[("rigid", "faulted")] = SCRIPTS[("quasi-static", "faulted")]
STEP_S = 0.12
SLOW_S = 0.3
#: Longest wait [s] for an answer of the node (a loaded machine answers late, not never).
ANSWER_S = 30.0


def slow_move(piston: str = "drs_piston"):
    """A JointTrajectory of the piston to mid-stroke, reached after SLOW_S."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from drs_model import DRSParams
    from drs_model.kinematics import stroke_limits

    s_min, s_max = stroke_limits(DRSParams())
    point = JointTrajectoryPoint(
        positions=[0.5 * (s_min + s_max)],
        time_from_start=Duration(sec=0, nanosec=int(SLOW_S * 1e9)),
    )
    return JointTrajectory(joint_names=[piston], points=[point])


def _remaps(launch: list[str]) -> dict[str, str]:
    """The ``-r FROM:=TO`` items of ``launch``."""
    pairs = [launch[i + 1] for i, item in enumerate(launch[:-1]) if item in ("-r", "--remap")]
    return dict(pair.split(":=", 1) for pair in pairs)


def node_name(launch: list[str]) -> str:
    """The node's fully qualified name under ``launch`` (``-r __ns:=`` and ``-r __node:=``)."""
    remaps = _remaps(launch)
    return f"{remaps.get('__ns', '').rstrip('/')}/{remaps.get('__node', 'drs')}"


def topic(launch: list[str], name: str) -> str:
    """The name the node gives its topic ``name`` (``~/x`` private, ``/x`` absolute) under
    ``launch``: in its namespace, remapped."""
    fqn = node_name(launch)

    def full(n: str) -> str:
        if n.startswith("~/"):
            return f"{fqn}/{n[2:]}"
        return n if n.startswith("/") else f"{fqn.rsplit('/', 1)[0]}/{n}"

    remapped = {full(k): full(v) for k, v in _remaps(launch).items() if not k.startswith("__")}
    return remapped.get(full(name), full(name))


def run_node(tmp_path, domain: int, rung: str, script: list, launch: list[str]):
    """Start the node as a process with ``launch``, drive it through ``script`` from a client
    (its service, its parameter service), stop it with SIGINT; the bag and what the parameter
    service answered."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter_client import AsyncParameterClient
    from std_srvs.srv import SetBool
    from trajectory_msgs.msg import JointTrajectory

    bag = tmp_path / "bag"
    args = node_command({"fidelity": rung, "bag_path": bag}, ros_args=launch)
    proc = subprocess.Popen(
        args,
        env=node_env(tmp_path, domain),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    client = rclpy.create_node("check_rungs_client", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(client)
    fqn = node_name(launch)
    answers = []
    try:
        drs = client.create_client(SetBool, f"{fqn}/drs")
        params = AsyncParameterClient(client, fqn)
        moves = client.create_publisher(JointTrajectory, topic(launch, "~/trajectory_cmd"), 10)
        assert drs.wait_for_service(timeout_sec=60.0), "the node never offered its service"
        assert params.wait_for_services(ANSWER_S)
        assert spin_until(ex, lambda: moves.get_subscription_count() > 0, ANSWER_S)
        for step in script:
            if step == "slow":
                moves.publish(slow_move())
                spin_for(ex, SLOW_S)
            elif isinstance(step, str):
                answer = call_answered(ex, drs, SetBool.Request(data=step == "open"), ANSWER_S)
                assert answer is not None and answer.success, answer
            else:
                fut = params.set_parameters_atomically(step)
                assert spin_until(ex, fut.done, ANSWER_S)
                answers.append(fut.result().result)
            spin_for(ex, STEP_S)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            out, _ = proc.communicate(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
        ex.shutdown()
        client.destroy_node()
        rclpy.try_shutdown(context=ctx)
    assert proc.returncode == 0, out[-3000:]
    return bag, answers


def verb_json(*argv: str) -> tuple[int, dict]:
    """``drs-bag VERB ... --json`` in this process: exit status and report."""
    from drs_ros.bag.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main([*argv, "--json"])
    return rc, json.loads(buf.getvalue())


def failed(report: dict) -> set[str]:
    return {c["name"] for c in report["checks"] if c["status"] == "FAIL"}


def _fastest_state(bag, js: str) -> int:
    """The index of the joint state with the fastest stroke (moving: no check leaves it out)."""
    from decoded_support import read_bag

    states = read_bag(bag, [js]).messages[js]
    speeds = [abs(m.velocity[0]) for _, m in states]
    return max(range(len(speeds)), key=speeds.__getitem__)


def _last(bag, topic: str) -> int:
    from decoded_support import read_bag

    return len(read_bag(bag, [topic]).messages[topic]) - 1


def tamper(bag, out, rung: str, case: str, launch: list[str]) -> set[str]:
    """A copy of ``bag`` with one recorded value changed; the checks that must fail."""
    force_topic, js = topic(launch, "~/piston_force"), topic(launch, "/joint_states")
    supply = topic(launch, "~/supply_pressure")
    if case == "healthy":
        k = _fastest_state(bag, js)
        if rung == "hydraulic":  # a chamber pressure 1 bar off: the force no longer matches it
            edits = {topic(launch, "~/pressure_piston_side"): (k, "fluid_pressure", 1e5)}
            expect = {"piston force vs chamber pressures"}
        else:  # the force changed alike in both places it is published
            value = 50.0 if rung == "kinematic" else 5.0
            edits = {js: (k, "effort", value), force_topic: (k, "data", value)}
            expect = {
                "kinematic": {"no piston force (kinematic rung)"},
                "quasi-static": {"piston force vs statics"},
                "rigid": {"piston force vs model, logged accel."},
            }[rung]
    elif rung == "kinematic":  # the frozen sensor's last reading, 0.1 mm off
        edits = {js: (_last(bag, js), "position", 1e-4)}
        expect = {"stroke vs faulty sensor model"}
    elif rung == "hydraulic":  # the supply, down to return pressure after the loss, 1 bar off
        edits = {supply: (_last(bag, supply), "fluid_pressure", 1e5)}
        expect = {"supply pressure vs faults"}
    else:  # a force where the supply is lost
        k = _last(bag, js)
        edits = {js: (k, "effort", 5.0), force_topic: (k, "data", 5.0)}
        expect = {"piston force under supply loss"}

    def change(topic, index, msg):
        if topic not in edits or edits[topic][0] != index:
            return None
        _, field, delta = edits[topic]
        if field in ("effort", "position"):
            values = list(getattr(msg, field))
            values[0] = delta if math.isnan(values[0]) else values[0] + delta
            setattr(msg, field, values)
        else:
            value = getattr(msg, field)
            setattr(msg, field, delta if math.isnan(value) else value + delta)
        return msg

    assert tampered_copy(bag, out, change) == len(edits)
    return expect


@pytest.mark.parametrize("launch", list(LAUNCHES.values()), ids=list(LAUNCHES))
@pytest.mark.parametrize("case", ["healthy", "faulted"])
@pytest.mark.parametrize("rung", RUNGS)
def test_a_run_is_judged_by_the_model_that_ran_it(tmp_path, request, rung, case, launch):
    script = SCRIPTS[(rung, case)]
    bag, answers = run_node(tmp_path, domain_for(request.node.nodeid), rung, script, launch)
    assert all(a.successful for a in answers), [a.reason for a in answers]

    rc, report = verb_json("check", str(bag))
    assert rc == 0, report["checks"]
    notes = " ".join(report["notes"])
    assert f"judged on the {rung} rung" in notes
    names = {c["name"] for c in report["checks"]}
    set_faults = {p.name for s in script if not isinstance(s, str) for p in s}
    assert {f["fault"] for f in report["faults"]} == set_faults  # each fault's span listed
    for span in report["faults"]:
        assert 0 < span["sim_from_s"] and 0 < span["log_from_ns"]
        if span["fault"] == "fault.stuck_valve":  # set, then cleared
            assert span["sim_from_s"] < span["sim_to_s"] and span["log_to_ns"] is not None
    if case == "faulted":
        sensor = next(c for c in report["checks"] if c["name"] == "stroke vs faulty sensor model")
        assert sensor["samples"] > 3 and sensor["status"] == "ok"
    if rung == "kinematic":
        assert "no piston force (kinematic rung)" in names
    if rung == "hydraulic":
        assert {"piston force vs chamber pressures", "supply pressure vs faults"} <= names

    rc, rerun = verb_json("resimulate", str(bag))
    assert rc == 0 and all(r["max_deviation"] == 0.0 for r in rerun["signals"]), rerun

    expect = tamper(bag, tmp_path / "tampered", rung, case, launch)
    rc, report = verb_json("check", str(tmp_path / "tampered"))
    assert rc == 1 and expect <= failed(report), report["checks"]


def test_a_fault_record_the_model_refuses_is_a_verdict(tmp_path, request):
    """An effect record whose accepted leak is negative (no node accepts it): check says FAIL
    with the record, not an internal error."""
    script = ["open", [_p("leak_m3_per_s_per_pa", 2e-12)]]
    bag, _ = run_node(tmp_path, domain_for(request.node.nodeid), "hydraulic", script, [])

    def change(topic, index, msg):
        if topic != "/drs/command_events":
            return None
        status = msg.status[0]
        if status.name != "fault.leak_m3_per_s_per_pa":
            return None
        for kv in status.values:
            if kv.key == "value":
                kv.value = "-1.0"
        return msg

    assert tampered_copy(bag, tmp_path / "tampered", change) == 1
    rc, report = verb_json("check", str(tmp_path / "tampered"))
    assert rc == 1, report
    row = next(c for c in report["checks"] if c["name"] == "recorded faults")
    assert row["status"] == "FAIL" and "fault.leak_m3_per_s_per_pa = '-1.0'" in row["note"]
    assert "must be in [0, " in row["note"]  # the fault's physical range, named
