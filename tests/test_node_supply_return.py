"""The node's supply loss cleared mid-run (``fault.supply_loss`` set back to false through the
parameter service) and the flap opened again: the hydraulic node's run, as its bag records it,
against the chart's reference re-run on the same recorded commands (the rung stepped with RK4
at a sixteenth of its stable sub-step, events located)."""

from __future__ import annotations

import math

import pytest
from node_support import domain_for, node_with_client, spin_for, spin_until
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

require_rclpy()

from rclpy.parameter import Parameter  # noqa: E402
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402

from drs_model.fidelity.ladder import REFERENCE  # noqa: E402
from drs_ros.bag.read.recorded_run import read_run, run_params  # noqa: E402
from drs_ros.bag.replay.rerun import resimulate  # noqa: E402


def _record(tmp_path):
    """A hydraulic node opened through its service; the supply lost 0.15 s later, back 0.25 s
    after that, and the flap opened again 0.03 s later; the bag."""
    bag = tmp_path / "bag"
    overrides = [Parameter("fidelity", value="hydraulic"), Parameter("bag_path", value=str(bag))]
    with node_with_client(
        int(domain_for("test_node_supply_return")), overrides, "drs_supply_return_client"
    ) as (_, client, ex):
        params = AsyncParameterClient(client, "/drs")
        drs = client.create_client(SetBool, "/drs/drs")
        assert drs.wait_for_service(timeout_sec=10.0) and params.wait_for_services(10.0)

        def call(future):
            assert spin_until(ex, future.done, 5.0)
            return future.result()

        assert call(drs.call_async(SetBool.Request(data=True))).success
        spin_for(ex, 0.15)
        for lost, wait in ((True, 0.25), (False, 0.03)):
            (result,) = call(
                params.set_parameters([Parameter("fault.supply_loss", value=lost)])
            ).results
            assert result.successful, result.reason
            spin_for(ex, wait)
        assert call(drs.call_async(SetBool.Request(data=True))).success
        spin_for(ex, 0.3)
    return bag


def _run(rerun, steps):
    """``(t, stroke, gap, p_A, p_B)`` of each step of a re-run (its kept state and its rung's
    chamber pressures there)."""
    out = []
    for k in steps:
        q, _, _, gap, _ = rerun["state_at"](k)
        sim = rerun["sim"]
        assert abs(sim.t - k * rerun["dt"]) < 1e-9
        out.append((sim.t, q[0], gap, *sim.chamber_pressures()))
    return out


def _reopening(run, t_open, p):
    """The time [s] from ``t_open`` to the gap's first reaching 95 % of its travel."""
    span = p.gap_open - p.gap_closed
    for t, _, gap, _, _ in run:
        if t > t_open and gap >= p.gap_closed + 0.95 * span:
            return t - t_open
    return math.inf


def test_the_flap_reopens_after_the_supply_returns_as_in_the_reference(tmp_path):
    """The node's run (its re-run on the recorded commands, which the bag reproduces exactly:
    tests/test_node_faults.py) stays within 10 um of stroke and 1 bar of either chamber pressure
    of the reference's re-run from the loss to the end; the rod side cavitated and its cavity
    closed again; the re-opening reaches 95 % of the gap in the same step."""
    run = read_run(_record(tmp_path))
    model = run_params(run.node_parameters)
    faults = [r for r in run.records if r.source == "fault.supply_loss" and r.outcome == "accepted"]
    assert [r.values["value"] for r in faults] == ["True", "False"]
    t_loss, t_back = faults[0].sim_time, faults[1].sim_time
    opens = [
        r.sim_time
        for r in run.records
        if r.sim_time > t_back and "drs" in r.source and r.outcome == "accepted"
    ]
    assert opens, [(r.source, r.outcome, r.sim_time) for r in run.records]
    node = resimulate(run, model)
    ref = resimulate(run, model, rung_options=REFERENCE[2])
    dt = node["dt"]
    steps = range(round(t_loss / dt), round((opens[0] + 0.2) / dt))
    ours, theirs = _run(node, steps), _run(ref, steps)
    for i, (what, tol) in enumerate((("stroke", 1e-5), ("gap", 1e-5), ("p_A", 1e5), ("p_B", 1e5))):
        worst = max(abs(a[i + 1] - b[i + 1]) for a, b in zip(ours, theirs, strict=True))
        assert worst < tol, (what, worst)
    rod_side = [r[4] for r in ours]
    floor = node["sim"].hydraulic.vapour_pressure
    assert min(rod_side) == floor and rod_side[-1] > 10 * floor  # a cavity opened and closed
    assert _reopening(ours, opens[0], model) == pytest.approx(
        _reopening(theirs, opens[0], model), abs=0.5 * dt
    )
    assert _reopening(ours, opens[0], model) < 0.2
