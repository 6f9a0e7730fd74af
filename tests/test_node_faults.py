"""Faults as run-time parameters of the node (drs_ros.node.fault_parameters): set with
``set_parameters`` through the parameter service, refused with a reason when bad or not
modelled by the rung, recorded on /parameter_events and in the effect record at the tick they
act, in diagnostics, and re-simulated exactly by ``drs-bag resimulate``."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest
from node_support import spin_for, spin_until
from ros_support import require_rclpy, resimulate_json

pytestmark = pytest.mark.ros

require_rclpy()

from rclpy.parameter import Parameter  # noqa: E402
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402

from drs_ros.node import DRSNode  # noqa: E402

#: (parameters set in one call, whether the node takes them), in order, each after 0.1 s
STEPS = (
    ([Parameter("fault.leak_m3_per_s_per_pa", value=2e-12)], True),
    (
        [
            Parameter("fault.sensor.bias_m", value=1e-3),
            Parameter("fault.sensor.noise_std_m", value=1e-4),
            Parameter("fault.sensor.noise_seed", value=11),
        ],
        True,
    ),
    ([Parameter("fault.leak_m3_per_s_per_pa", value=-1.0)], False),  # negative: refused
    ([Parameter("fault.sensor.dropout", value=0.25)], True),
    ([Parameter("fault.stuck_valve", value=True)], True),
    ([Parameter("fault.stuck_valve", value=False)], True),
    (
        [
            Parameter("fault.supply_loss", value=True),
            Parameter("fault.supply_loss_ramp_s", value=0.05),
        ],
        True,
    ),
    ([Parameter("fault.sensor.frozen", value=True)], True),
)


@pytest.fixture(scope="module")
def faulty_bag(tmp_path_factory):
    """A hydraulic node opened through the service, then the faults of STEPS set through the
    parameter service (as ``ros2 param set`` does), 0.1 s apart; what the client saw."""
    from node_support import hydraulic_node_in

    out = tmp_path_factory.mktemp("faults")
    joints: list = []
    results = []
    fixture = "test_node_faults::faulty_bag"
    with hydraulic_node_in(out, fixture, "drs_faults_client") as (node, client, ex):
        client.create_subscription(JointState, "/joint_states", joints.append, 100)
        params = AsyncParameterClient(client, "/drs")
        drs = client.create_client(SetBool, "/drs/drs")
        assert drs.wait_for_service(timeout_sec=10.0) and params.wait_for_services(10.0)
        fut = drs.call_async(SetBool.Request(data=True))
        assert spin_until(ex, fut.done, 5.0) and fut.result().success
        spin_for(ex, 0.1)
        for plist, _ in STEPS:
            fut = params.set_parameters_atomically(plist)
            assert spin_until(ex, fut.done, 5.0)
            results.append(fut.result().result)
            spin_for(ex, 0.1)
        diagnostics = node.diagnostics_values()
    return out / "bag", results, diagnostics, joints


def test_faults_are_taken_or_refused_with_a_reason(faulty_bag):
    _, results, diagnostics, _ = faulty_bag
    assert [r.successful for r in results] == [ok for _, ok in STEPS]
    refused = results[2]
    assert "fault.leak_m3_per_s_per_pa" in refused.reason and "[0, 1e-10]" in refused.reason
    # in force at the end, in diagnostics (the refused -1.0 never took)
    assert "leak_m3_per_s_per_pa=2e-12" in diagnostics["faults"]
    assert "supply_loss=True" in diagnostics["faults"]
    assert "stuck_valve" not in diagnostics["faults"]  # set and cleared


def test_each_fault_is_recorded_where_it_took_effect(faulty_bag):
    from decoded_support import read_bag

    from drs_ros.bag.read.effects import effect_records

    bag, _, _, joints = faulty_bag
    data = read_bag(bag, ["/drs/command_events", "/parameter_events", "/joint_states"])
    records = [
        r
        for r in effect_records(data.messages["/drs/command_events"])
        if r.source.startswith("fault.")
    ]
    taken = [(p.name, p.value) for plist, ok in STEPS if ok for p in plist]
    # within a call, a ramp acts before the supply loss it shapes
    i = taken.index(("fault.supply_loss", True))
    taken[i], taken[i + 1] = taken[i + 1], taken[i]
    accepted = [(r.source, r.values["value"]) for r in records if r.outcome == "accepted"]
    assert accepted == [(n, repr(v)) for n, v in taken]
    refused = [r for r in records if r.outcome == "refused"]
    assert [(r.source, r.values["value"]) for r in refused] == [
        ("fault.leak_m3_per_s_per_pa", "-1.0")
    ]
    times = [r.sim_time for r in records if r.outcome == "accepted"]
    assert times == sorted(times) and times[0] > 0.09  # each at a tick, after the open
    # every change taken is on /parameter_events in the bag, the refused one is not
    changed = [
        (p.name, p) for _, ev in data.messages["/parameter_events"] for p in ev.changed_parameters
    ]
    assert sorted({n for n, _ in changed}) == sorted({n for n, _ in taken})
    # the published stroke: dropouts (NaN) appear only after the dropout was set
    published = [m.position[0] for _, m in data.messages["/joint_states"]]
    assert any(math.isnan(s) for s in published)
    assert not any(math.isnan(m.position[0]) for m in joints[:5])


def test_a_bag_with_faults_re_runs_exactly(faulty_bag):
    bag, _, _, _ = faulty_bag
    rc, report = resimulate_json(str(bag))
    assert rc == 0, report
    assert all(r["max_deviation"] == 0.0 for r in report["signals"]), report["signals"]
    assert all(r["samples"] > 20 for r in report["signals"]), report["signals"]
    # on the rigid rung the hydraulic faults are refused, each said
    rc, report = resimulate_json(str(bag), "--fidelity", "rigid")
    assert any("fault.stuck_valve" in n and "cannot model" in n for n in report["notes"])


def test_a_fault_the_rung_cannot_model_is_refused(ros_context):
    node = DRSNode(context=ros_context)  # rigid
    try:
        (result,) = node.set_parameters([Parameter("fault.stuck_valve", value=True)])
        assert not result.successful
        assert "'rigid' rung cannot model fault stuck_valve" in result.reason
        assert node.get_parameter("fault.stuck_valve").value is False
        (result,) = node.set_parameters([Parameter("fault.sensor.bias_m", value=1e-3)])
        assert result.successful  # sensor faults: every rung
        (result,) = node.set_parameters([Parameter("fault.sensor.dropout", value=1.5)])
        assert not result.successful and "[0, 1]" in result.reason
        node.tick()
        assert node.fault_parameters.faults.active() == {"sensor.bias_m": 1e-3}
        assert node.effects.refused == 2
    finally:
        node.destroy_node()


def _auto_run(tmp_path, domain_key, topics, bag=True):
    """A ``fidelity: auto`` node with a client subscribed to ``topics`` (name -> type), 0.2 s
    to discover them, then open through the service and run 0.3 s; the node's chosen rung."""
    from node_support import domain_for, node_with_client

    overrides = [
        Parameter("fidelity", value="auto"),
        Parameter("fidelity_auto_discovery_s", value=0.5),
    ]
    if bag:
        overrides.append(Parameter("bag_path", value=str(tmp_path / "bag")))

    def subscribe(client) -> None:
        for topic, msg_type in topics.items():
            client.create_subscription(msg_type, topic, lambda _m: None, 10)

    with node_with_client(
        int(domain_for(domain_key)), overrides, "drs_auto_client", before_node=subscribe
    ) as (node, client, ex):
        drs = client.create_client(SetBool, "/drs/drs")
        assert drs.wait_for_service(timeout_sec=10.0)
        spin_for(ex, 0.6)  # auto chooses at the first tick after 0.5 s
        fut = drs.call_async(SetBool.Request(data=True))
        assert spin_until(ex, fut.done, 5.0) and fut.result().success
        spin_for(ex, 0.3)
        return node.sim.name


def test_auto_takes_kinematic_for_the_gap_and_a_bag_re_runs_on_it(tmp_path, monkeypatch):
    from decoded_support import read_bag
    from std_msgs.msg import Float64

    from drs_ros.bag.read.effects import effect_records

    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    rung = _auto_run(tmp_path, "test_node_faults::auto_gap", {"/drs/flap_gap": Float64})
    assert rung == "kinematic"
    data = read_bag(tmp_path / "bag", ["/drs/command_events"])
    (choice,) = [
        r for r in effect_records(data.messages["/drs/command_events"]) if r.source == "fidelity"
    ]
    assert choice.values["rung"] == "kinematic" and choice.values["asked"] == "gap"
    assert choice.sim_time == 0.0
    rc, report = resimulate_json(str(tmp_path / "bag"))
    assert rc == 0 and report["signals"][0]["samples"] > 20, report
    # every signal to the bit (the kinematic rung's force is NaN in both)
    assert all(r["max_deviation"] == 0.0 for r in report["signals"]), report["signals"]
    # check judges it on the rung auto chose (no force), read from the effect record
    out = subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.cli", "check", str(tmp_path / "bag"), "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    check = json.loads(out.stdout)
    assert any("kinematic rung (fidelity auto's choice" in n for n in check["notes"])
    assert any(
        c["name"] == "no piston force (kinematic rung)" and c["status"] == "ok"
        for c in check["checks"]
    )


@pytest.mark.parametrize(
    ("topic", "asks"),
    [("/drs/piston_force", "force"), ("/drs/pressure_piston_side", "hydraulics")],
)
def test_auto_takes_the_rung_the_subscribers_need(tmp_path, monkeypatch, topic, asks):
    """The rung the rule gives, by the errors measured now (drs_model.fidelity.auto, tested
    against ``drs fidelity`` in test_fidelity_auto), at the node's default tolerances."""
    from sensor_msgs.msg import FluidPressure
    from std_msgs.msg import Float64

    from drs_model.fidelity.auto import choose_rung, ladder_errors
    from drs_ros.node.parameters import NODE_PARAMETERS

    default = {name: value for name, value, *_ in NODE_PARAMETERS}
    rung = choose_rung(
        {"gap", asks},
        default["fidelity_tolerance"],
        default["fidelity_force_tolerance"],
        ladder_errors(),
    )
    assert asks == "force" or rung == "hydraulic"
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    msg_type = FluidPressure if "pressure" in topic else Float64
    topics = {topic: msg_type, "/joint_states": JointState}
    assert _auto_run(tmp_path, f"test_node_faults::auto_{asks}", topics, bag=False) == rung
