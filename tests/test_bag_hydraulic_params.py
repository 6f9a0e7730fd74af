"""The hydraulic parameters end to end: a bag records the HydraulicParams its node ran
(``hydraulic.*``), ``drs-bag resimulate`` re-runs with them (not with HydraulicParams'
defaults), ``--set`` takes them, and what ``drs-bag fit`` finds re-runs the bag closer than the
defaults do."""

from __future__ import annotations

import json

import pytest
from ros_support import require_rclpy
from test_bag_fit import drs_bag

from drs_model.fidelity import HydraulicParams

#: The actuator of the bag: HydraulicParams' defaults but a stiffer seal and a leak outside.
TRUTH = {"leak_to_outside": 2e-13, "coulomb_friction": 70.0, "breakaway_friction": 90.0}


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    require_rclpy()
    from run_support import Command, record_run

    out = tmp_path_factory.mktemp("hydraulic_params")
    return record_run(out / "bag", 130, [Command(1, "drs", True), Command(70, "drs", False)],
                      fidelity="hydraulic", hydraulic_params=HydraulicParams(**TRUTH),
                      faults={"sensor.noise_std_m": 1e-5, "sensor.noise_seed": 3})  # fmt: skip


def _stroke_deviation(bag, *sets: str) -> tuple[int, float]:
    args = ["resimulate", str(bag), "--json"]
    for item in sets:
        args += ["--set", item]
    res = drs_bag(*args)
    rows = {r["signal"]: r for r in json.loads(res.stdout)["signals"]}
    return res.returncode, float(rows["stroke"]["max_deviation"])


def test_the_bag_records_and_re_runs_its_hydraulic_parameters(bag):
    """Recorded as run; re-run with them exactly; with HydraulicParams' defaults it deviates."""
    from drs_ros.bag.effects import hydraulic_params_from
    from drs_ros.bag.nodes import bag_nodes

    (node,) = bag_nodes(bag)
    assert hydraulic_params_from(node.parameters) == HydraulicParams(**TRUTH)
    assert node.parameters["hydraulic.valve_port_ratio"] == pytest.approx(0.75, rel=1e-15)
    assert _stroke_deviation(bag) == (0, 0.0)
    defaults = HydraulicParams()
    status, deviation = _stroke_deviation(
        bag, *(f"{k}={getattr(defaults, k)!r}" for k in TRUTH))
    assert status == 1 and deviation > 1e-6  # DEVIATES: the defaults are not what ran


def test_a_fit_re_runs_the_bag_closer_than_the_defaults(bag):
    """Fit from HydraulicParams' defaults (``--set``), re-run with the fitted values (``--set``):
    the stroke's deviation falls well below the defaults'."""
    defaults = HydraulicParams()
    start = [f"hydraulic.{k}={getattr(defaults, k)!r}" for k in TRUTH]  # as the node names them
    args = ["fit", str(bag), "--params", ",".join(TRUTH), "--json"]
    for item in start:
        args += ["--set", item]
    res = drs_bag(*args)
    assert res.returncode == 0, res.stdout + res.stderr
    fitted = {e["name"]: e["value"] for e in json.loads(res.stdout)["estimates"]
              if e["stage"] == "output"}  # fmt: skip
    assert set(fitted) == set(TRUTH)
    _, with_defaults = _stroke_deviation(bag, *start)
    _, with_fitted = _stroke_deviation(bag, *(f"{k}={v!r}" for k, v in fitted.items()))
    assert with_fitted < 0.2 * with_defaults, (with_fitted, with_defaults, fitted)
