"""The node on the fidelity ladder: the ``fidelity`` parameter, the hydraulic rung's pressures
and spool on standard message types, recorded, and ``drs-bag resimulate --fidelity``."""

from __future__ import annotations

import pytest
from node_support import spin_until
from ros_support import require_rclpy, resimulate_json

pytestmark = pytest.mark.ros

require_rclpy()

from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import FluidPressure, JointState  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402

from drs_model.fidelity import HydraulicParams  # noqa: E402
from drs_ros.node import DRSNode  # noqa: E402
from drs_ros.node.parameters import StartupError  # noqa: E402

HYDRAULIC = (
    "/drs/pressure_piston_side",
    "/drs/pressure_rod_side",
    "/drs/supply_pressure",
    "/drs/valve_spool",
)


@pytest.fixture(scope="module")
def hydraulic_bag(tmp_path_factory):
    """A hydraulic node's run: open through the service, 0.3 s, close, 0.3 s; the pressures it
    published as a subscriber saw them."""
    from node_support import hydraulic_node_in

    out = tmp_path_factory.mktemp("hydraulic")
    seen = {"pa": [], "joints": []}
    fixture = "test_node_fidelity::hydraulic_bag"
    with hydraulic_node_in(out, fixture, "drs_fidelity_client") as (node, client, ex):
        client.create_subscription(FluidPressure, HYDRAULIC[0], seen["pa"].append, 100)
        client.create_subscription(JointState, "/joint_states", seen["joints"].append, 100)
        drs = client.create_client(SetBool, "/drs/drs")
        assert drs.wait_for_service(timeout_sec=10.0)
        assert spin_until(ex, lambda: len(seen["pa"]) > 3, 10.0), "no pressures published"
        for value in (True, False):
            fut = drs.call_async(SetBool.Request(data=value))
            assert spin_until(ex, fut.done, 5.0) and fut.result().success
            # 0.3 s of simulated time, however slowly a loaded machine runs it: the
            # valve's swing each way takes tens of ms of it
            t_end = node.sim.t + 0.3
            assert spin_until(ex, lambda t_end=t_end: node.sim.t >= t_end, 60.0)
    return out / "bag", seen


def test_the_hydraulic_node_publishes_and_records_its_pressures(hydraulic_bag):
    from decoded_support import read_bag

    from drs_ros.bag.read.effects import recorded_node_parameters

    bag, seen = hydraulic_bag
    hp = HydraulicParams()
    assert all(hp.return_pressure < m.fluid_pressure < hp.relief_pressure for m in seen["pa"])
    assert seen["pa"][-1].header.frame_id == "drs_base"
    assert max(m.position[0] for m in seen["joints"]) > 0.045  # it opened (slower than 10 ms)
    data = read_bag(bag, [*HYDRAULIC, "/parameter_events", "/joint_states"])
    params = recorded_node_parameters(data.messages["/parameter_events"])
    assert params["fidelity"] == "hydraulic"
    joints = data.messages["/joint_states"]
    for topic in HYDRAULIC:  # published with every joint state, stamped alike
        assert len(data.messages[topic]) == len(joints) > 10, topic
    stamps = [m.header.stamp for _, m in data.messages[HYDRAULIC[0]]]
    assert stamps == [m.header.stamp for _, m in joints]
    supply = {m.fluid_pressure for _, m in data.messages["/drs/supply_pressure"]}
    assert supply == {hp.supply_pressure}
    spool = [m.data for _, m in data.messages["/drs/valve_spool"]]
    assert max(spool) > 0.9 and min(spool) < -0.9  # the valve opened both ways


def test_a_hydraulic_bag_re_runs_exactly_and_on_another_rung(hydraulic_bag):
    bag, _ = hydraulic_bag
    rc, report = resimulate_json(str(bag))
    assert rc == 0, report
    assert all(r["max_deviation"] == 0.0 for r in report["signals"]), report["signals"]
    rc, report = resimulate_json(str(bag), "--fidelity", "rigid")
    assert rc == 1 and report["fidelity"] == "rigid"
    rows = {r["signal"]: r for r in report["signals"]}
    assert rows["stroke"]["max_deviation"] > 0.01  # the rigid rung opens in 10 ms, not ~55 ms


def test_a_rigid_bag_re_runs_on_the_kinematic_rung(node_bag):
    """The demo's bag (rigid, with force commands): on the kinematic rung the force commands are
    refused, which the report says, and the positions of the stroke moves stay."""
    rc, report = resimulate_json(str(node_bag), "--fidelity", "kinematic")
    assert rc == 1
    assert any("'kinematic' rung cannot represent a force command" in n for n in report["notes"])


def test_an_unknown_fidelity_is_refused(ros_context):
    with pytest.raises(StartupError, match=r"fidelity must be one of \['kinematic'"):
        DRSNode(context=ros_context, parameter_overrides=[Parameter("fidelity", value="exact")])
