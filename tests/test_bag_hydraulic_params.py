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
    return record_run(
        out / "bag",
        130,
        [Command(1, "drs", True), Command(70, "drs", False)],
        fidelity="hydraulic",
        hydraulic_params=HydraulicParams(**TRUTH),
        faults={"sensor.noise_std_m": 1e-5, "sensor.noise_seed": 3},
    )


def _stroke_deviation(bag, *sets: str) -> tuple[int, float]:
    args = ["resimulate", str(bag), "--json"]
    for item in sets:
        args += ["--set", item]
    res = drs_bag(*args)
    rows = {r["signal"]: r for r in json.loads(res.stdout)["signals"]}
    return res.returncode, float(rows["stroke"]["max_deviation"])


def test_the_bag_records_and_re_runs_its_hydraulic_parameters(bag):
    """Recorded as run; re-run with them exactly; with HydraulicParams' defaults it deviates."""
    from drs_ros.bag.read.effects import hydraulic_params_from
    from drs_ros.bag.read.nodes import bag_nodes

    (node,) = bag_nodes(bag)
    assert hydraulic_params_from(node.parameters) == HydraulicParams(**TRUTH)
    assert node.parameters["hydraulic.valve_port_ratio"] == pytest.approx(0.75, rel=1e-15)
    assert _stroke_deviation(bag) == (0, 0.0)
    defaults = HydraulicParams()
    status, deviation = _stroke_deviation(bag, *(f"{k}={getattr(defaults, k)!r}" for k in TRUTH))
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
    fitted = {
        e["name"]: e["value"] for e in json.loads(res.stdout)["estimates"] if e["stage"] == "output"
    }
    assert set(fitted) == set(TRUTH)
    _, with_defaults = _stroke_deviation(bag, *start)
    _, with_fitted = _stroke_deviation(bag, *(f"{k}={v!r}" for k, v in fitted.items()))
    assert with_fitted < 0.2 * with_defaults, (with_fitted, with_defaults, fitted)


def _season_row(verb: str, bag, *args: str) -> dict:
    """The season-table row of one bag (what ``drs-bag VERB BAGS -o t.parquet`` writes per bag)."""
    import importlib

    from drs_ros.bag.cli import VERBS, build_parser

    parsed = build_parser(verb).parse_args([verb, str(bag), *args])
    (row,) = importlib.import_module(VERBS[verb][0]).fleet_row(str(bag), parsed)
    return row


def test_season_rows_carry_the_hydraulic_parameters_used(bag):
    """resimulate's row: the recorded values, a ``--set`` one as set; fit's row: its start."""
    row = _season_row("resimulate", bag, "--set", "hydraulic.coulomb_friction=75")
    assert row["param_hydraulic.leak_to_outside"] == TRUTH["leak_to_outside"]
    assert row["param_hydraulic.coulomb_friction"] == 75.0
    assert row["param_hydraulic.flow_law"] == HydraulicParams().flow_law
    row = _season_row(
        "fit", bag, "--params", "leak_to_outside", "--stage", "equation", "--set", "flow_law=linear"
    )
    assert row["param_hydraulic.breakaway_friction"] == TRUTH["breakaway_friction"]
    assert row["param_hydraulic.flow_law"] == "linear"


def test_a_bag_without_hydraulic_parameters_has_no_such_columns(tmp_path):
    from ros_support import write_drs_bag

    from drs_model.params import DRSParams

    write_drs_bag(tmp_path / "other", DRSParams(), n=50)
    for verb, args in (("resimulate", ()), ("fit", ("--params", "m_pist"))):
        row = _season_row(verb, tmp_path / "other", *args)
        assert not [c for c in row if c.startswith("param_hydraulic.")], (verb, row)
        assert "param_m_pist" in row


def _check(bag, tmp_path, values: dict | None = None):
    args = ["check", str(bag), "--json"]
    if values is not None:
        (tmp_path / "p.toml").write_text("".join(f"{k} = {v!r}\n" for k, v in values.items()))
        args += ["--params", tmp_path / "p.toml"]
    return drs_bag(*args)


def test_check_judges_the_hydraulic_rung_with_the_recorded_values_or_the_files(bag, tmp_path):
    """The recorded values pass; a ``--params`` file's hydraulic values are used over them
    (the defaults' friction and leak are not what ran: the rod force check fails)."""
    assert _check(bag, tmp_path).returncode == 0, _check(bag, tmp_path).stdout
    defaults = HydraulicParams()
    res = _check(bag, tmp_path, {k: getattr(defaults, k) for k in TRUTH})
    assert res.returncode == 1, res.stdout + res.stderr
    res = _check(bag, tmp_path, dict(TRUTH))
    assert res.returncode == 0, res.stdout + res.stderr


def test_check_refuses_hydraulic_values_for_a_run_of_another_rung(tmp_path):
    from ros_support import write_drs_bag

    from drs_model.params import DRSParams

    write_drs_bag(tmp_path / "rigid", DRSParams(), n=50)
    res = _check(tmp_path / "rigid", tmp_path, {"leak_to_outside": 1e-13})
    assert res.returncode == 2, res.stdout + res.stderr
    assert "leak_to_outside are hydraulic parameters" in res.stderr + res.stdout
    assert "no hydraulic model" in res.stderr + res.stdout
