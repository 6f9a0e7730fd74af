"""The node's parameter server holds what the model runs (real DDS, loopback only): the
``model.*`` and ``hydraulic.*`` parameters as served over the parameter services equal the
model's values (a derived inertia derived, model_params_file's values), are read-only, and equal
what the bag records; a value that would shadow model_params_file refuses to start; a
``hydraulic.*`` value out of its range refuses to start with the model's reason."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest
import yaml
from node_support import domain_for, spin_until, start_node
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

require_rclpy()

from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter, parameter_value_to_python  # noqa: E402
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402

from drs_ros.node import DRSNode  # noqa: E402
from drs_ros.node.parameters import StartupError  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / "config" / "drs.yaml"
L_WING = 0.12  # m, the seed's flap length: Iz_wing = m_wing L_wing^2 / 3 (a plate about its hinge)


def _result(ex, future, what: str):
    assert spin_until(ex, future.done, 30.0), f"no answer to {what}"
    return future.result()


def served_over_dds(ctx, node: DRSNode | None, name: str = "/drs") -> dict:
    """Every ``model.*`` and ``hydraulic.*`` value of ``node`` (in this process; None: the
    node ``name`` of another process) as another node gets it over the parameter services
    (what ``ros2 param get`` does), after checking each is read-only."""
    client = Node("param_reader", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    if node is not None:
        ex.add_node(node)
    ex.add_node(client)
    try:
        params = AsyncParameterClient(client, name)
        assert spin_until(ex, params.services_are_ready, 60.0), "no parameter services"
        names = list(
            _result(ex, params.list_parameters(["model", "hydraulic"]), "list").result.names
        )
        values = _result(ex, params.get_parameters(names), "get").values
        descriptors = _result(ex, params.describe_parameters(names), "describe").descriptors
        assert all(d.read_only for d in descriptors)
        refused = _result(
            ex, params.set_parameters([Parameter("model.Iz_wing", value=1.0)]), "set"
        ).results[0]
        assert not refused.successful and "read-only" in refused.reason
        return {n: parameter_value_to_python(v) for n, v in zip(names, values, strict=True)}
    finally:
        ex.shutdown()
        client.destroy_node()


def recorded(node: DRSNode, bag) -> dict:
    from drs_ros.bag.read.nodes import bag_nodes

    assert node.close_recordings() == []
    (bag_node,) = bag_nodes(bag)
    return bag_node.parameters


def test_the_served_values_are_the_run_s_and_the_recorded_ones(ros_context, tmp_path):
    """``model.m_wing:=3.0``: model.Iz_wing reads the derived 0.0144 the model runs, not the
    seed's 0.0096; a hydraulic value given reaches the hydraulic rung; served == recorded."""
    from drs_model.fidelity import HydraulicRung
    from drs_model.params import DRSParams
    from drs_ros.bag.read.effects import hydraulic_params_from, model_params_from

    bag = tmp_path / "bag"
    node = DRSNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("model.m_wing", value=3.0),
            Parameter("fidelity", value="hydraulic"),
            Parameter("hydraulic.leak_to_outside", value=1e-12),
            Parameter("hydraulic.coulomb_friction", value=50),  # an integer for a double
            Parameter("bag_path", value=str(bag)),
        ],
    )
    try:
        served = served_over_dds(ros_context, node)
        assert served["model.m_wing"] == 3.0
        assert served["model.Iz_wing"] == pytest.approx(3.0 * L_WING**2 / 3.0, rel=1e-15)
        assert served["model.Iz_wing"] != DRSParams().Iz_wing
        assert served["hydraulic.leak_to_outside"] == 1e-12
        assert served["hydraulic.coulomb_friction"] == 50.0
        assert isinstance(node.sim, HydraulicRung)
        assert node.sim.hydraulic.leak_to_outside == 1e-12
        assert node.sim.hydraulic.coulomb_friction == 50.0
        # the valve's port ratio runs as the area ratio (16 mm bore, 8 mm rod): 3/4
        assert served["hydraulic.valve_port_ratio"] == pytest.approx(0.75, rel=1e-15)
        got = recorded(node, bag)
        assert {k: got[k] for k in served} == served
        assert model_params_from(got) == node.params
        assert hydraulic_params_from(got) == node.sim.hydraulic
    finally:
        node.destroy_node()


def test_the_shipped_yaml_leaves_model_params_file_its_values(ros_context, tmp_path):
    """``--params-file config/drs.yaml`` with a model_params_file setting m_wing = 5 (and a
    hydraulic value): the node runs, serves and records 5 and the file's hydraulic value."""
    model_file = tmp_path / "car.toml"
    model_file.write_text("m_wing = 5.0\ncoulomb_friction = 55.0\n")
    bag = tmp_path / "bag"
    node = DRSNode(
        context=ros_context,
        cli_args=[
            "--ros-args",
            "--params-file",
            str(CONFIG),
            "-p",
            f"model_params_file:={model_file}",
            "-p",
            f"bag_path:={bag}",
        ],
    )
    try:
        assert node.params.m_wing == 5.0
        served = served_over_dds(ros_context, node)
        assert served["model.m_wing"] == 5.0
        assert served["model.Iz_wing"] == pytest.approx(5.0 * L_WING**2 / 3.0, rel=1e-15)
        assert served["hydraulic.coulomb_friction"] == 55.0
        got = recorded(node, bag)
        assert {k: got[k] for k in served} == served
    finally:
        node.destroy_node()


def test_a_parameter_file_that_shadows_model_params_file_is_refused(ros_context, tmp_path):
    """A ROS parameter file setting model.m_wing 2.0 and a model_params_file setting 5.0: the
    node refuses to start, naming the parameter and the file, and records nothing."""
    values = yaml.safe_load(CONFIG.read_text())
    values["/drs"]["ros__parameters"]["model"] = {"m_wing": 2.0}
    ros_file = tmp_path / "drs.yaml"
    ros_file.write_text(yaml.safe_dump(values))
    model_file = tmp_path / "car.toml"
    model_file.write_text("m_wing = 5.0\n")
    with pytest.raises(StartupError) as exc:
        DRSNode(
            context=ros_context,
            cli_args=[
                "--ros-args",
                "--params-file",
                str(ros_file),
                "-p",
                f"model_params_file:={model_file}",
                "-p",
                f"bag_path:={tmp_path / 'bag'}",
            ],
        )
    assert "model.m_wing:=2.0" in str(exc.value) and str(model_file) in str(exc.value)
    assert "5.0" in str(exc.value)
    assert not (tmp_path / "bag").exists()


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        (
            [Parameter("hydraulic.bulk_modulus", value=-1.0)],
            r"hydraulic\.bulk_modulus:=-1\.0: bulk_modulus must be > 0",
        ),
        (
            [Parameter("hydraulic.air_polytropic_index", value=2.0)],
            r"air_polytropic_index must be in \[1, 1\.4\]",
        ),
        ([Parameter("hydraulic.flow_law", value="laminar")], r"flow_law must be one of"),
    ],
)
def test_a_hydraulic_value_out_of_its_range_is_refused_with_the_reason(
    ros_context, overrides, match
):
    with pytest.raises(StartupError, match=match):
        DRSNode(context=ros_context, parameter_overrides=overrides)


def test_a_misspelt_hydraulic_parameter_is_refused_with_the_closest(ros_context):
    with pytest.raises(StartupError, match=r"did you mean 'hydraulic\.leak_to_outside'\?"):
        DRSNode(
            context=ros_context,
            parameter_overrides=[Parameter("hydraulic.leak_to_outsde", value=1e-12)],
        )


def test_a_managed_node_configured_again_serves_the_same_values(ros_context):
    node = DRSNode(
        context=ros_context,
        managed=True,
        parameter_overrides=[Parameter("model.m_wing", value=3.0)],
    )
    try:
        assert not node.has_parameter("model.m_wing")  # unknown until the model is built
        node.configure()
        first = node.get_parameter("model.Iz_wing").value
        node.cleanup()
        node.configure()
        assert node.get_parameter("model.Iz_wing").value == first
        assert first == pytest.approx(3.0 * L_WING**2 / 3.0, rel=1e-15)
    finally:
        node.destroy_node()


def test_drs_node_serves_what_its_bag_records(ros_context, tmp_path, request):
    """``drs-node -p model.m_wing:=3.0`` as its own process: what another process reads over
    DDS (``ros2 param get /drs model.Iz_wing``) is the derived 0.0144, and every served value
    is the one its bag records."""
    from dataclasses import fields

    from decoded_support import read_bag

    from drs_model.fidelity import HydraulicParams
    from drs_model.params import NUMERIC_FIELDS
    from drs_ros.bag.read.effects import recorded_node_parameters

    bag = tmp_path / "bag"
    proc = start_node(
        tmp_path, domain_for(request.node.nodeid), "model.m_wing:=3.0", f"bag_path:={bag}"
    )
    try:
        served = served_over_dds(ros_context, None)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out[-2000:]
    assert served["model.Iz_wing"] == pytest.approx(3.0 * L_WING**2 / 3.0, rel=1e-15)
    got = recorded_node_parameters(
        read_bag(bag, ["/parameter_events"]).messages["/parameter_events"]
    )
    assert {k: got[k] for k in served} == served
    # every DRSParams number and every HydraulicParams field
    assert len(served) == len(NUMERIC_FIELDS) + len(fields(HydraulicParams))
