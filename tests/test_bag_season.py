"""A season on Dask: ``drs-bag fit DIR --jobs N -o season.parquet`` then ``drs-bag trend``.
Forty bags of a leak growing 5 % per run are flagged, with the run at which the drift became
significant and the date a threshold is reached; forty healthy bags are not; two workers give
the table one gives."""

from __future__ import annotations

import contextlib
import io
import json
import math

import pytest
from ros_support import require_module, require_rclpy

RUNS = 40
DAY_NS = 86_400 * 10**9


def drs_bag(*args):
    from drs_ros.bag.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in args])
    return status, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def seasons(tmp_path_factory):
    """Two seasons of forty small hydraulic runs (the opening, 60 ms at 2 kHz), one a day, each
    with its own stroke noise: one whose leak to the outside grows 5 % a run from 1e-13
    m^3/(s Pa), one whose leak stays at 1e-13."""
    require_rclpy()
    require_module("distributed")
    from long_bag_support import T0_NS
    from run_support import Command, record_run

    out = tmp_path_factory.mktemp("season")
    for season, growth in (("worn", 1.05), ("healthy", 1.0)):
        for k in range(RUNS):
            faults = {
                "leak_m3_per_s_per_pa": 1e-13 * growth**k,
                "sensor.noise_std_m": 1e-5,
                "sensor.noise_seed": 100 * (season == "healthy") + k,
            }
            record_run(
                out / season / f"run_{k:02d}",
                120,
                [Command(1, "drs", True)],
                fidelity="hydraulic",
                physics_rate_hz=2000.0,
                faults=faults,
                t0_ns=T0_NS + k * DAY_NS,
            )
    return out


def _fit(bags, table, jobs, runs=RUNS):
    status, out, err = drs_bag(
        "fit",
        bags,
        "--params",
        "leak_to_outside",
        "--stage",
        "equation",
        "--jobs",
        jobs,
        "-o",
        table,
    )
    assert status == 0, out + err
    assert f"{runs} bags: {runs} FITTED" in out


def test_a_growing_leak_is_flagged_with_its_run_and_its_crossing(seasons):
    table = seasons / "worn.parquet"
    _fit(seasons / "worn", table, 2)
    status, out, err = drs_bag(
        "trend",
        table,
        "--threshold",
        "leak_to_outside=1e-12",
        "--json",
        "--plot",
        seasons / "worn.png",
    )
    assert status == 1, out + err
    (row,) = json.loads(out)
    assert row["drift"] == "rising" and row["model"] == "exponential"
    assert 8 <= row["detected_run"] <= 12 and row["detected_bag"].endswith(
        f"run_{row['detected_run'] - 1:02d}"
    )
    truth = math.log(10.0) / math.log(1.05) - (RUNS - 1)  # days after the last run: 8.2
    low, median, high = row["crossing"]["days_after_last_run"]
    assert abs(median - truth) < 1.5 and low < median < high
    assert (seasons / "worn.png").stat().st_size > 10_000


def test_a_healthy_season_raises_no_flag_and_two_workers_give_the_table_of_one(seasons):
    import pyarrow.parquet as pq

    two, one = seasons / "healthy_2.parquet", seasons / "healthy_1.parquet"
    _fit(seasons / "healthy", two, 2)
    _fit(f"{seasons}/healthy/run_0*", one, 1, runs=10)  # the first ten, on one worker
    a, b = pq.read_table(one).to_pydict(), pq.read_table(two).to_pydict()
    assert a.keys() == b.keys()
    for column in a:
        if column != "task_s":  # wall time of each task
            assert a[column] == b[column][:10], column
    status, out, err = drs_bag("trend", two)
    assert status == 0, out + err
    assert "drift: none" in out


def test_each_actuator_of_a_season_is_trended_on_its_own(tmp_path):
    """A car's two actuators in one table, their runs interleaved: the front one's leak grows
    5 % a run, the rear one's does not. The front one is flagged and the rear one is not (one
    trend of both would mix them); --node keeps one."""
    require_rclpy()
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    rng = np.random.default_rng(4)
    rows = []
    for k in range(RUNS):
        for node, growth in (("/car7/front/drs_front", 1.05), ("/car7/rear/drs_rear", 1.0)):
            value = 1e-13 * growth**k
            rows.append(
                {
                    "bag": f"runs/{node.rsplit('/', 1)[-1]}_{k:02d}",
                    "node": node,
                    "start_ns": k * DAY_NS,
                    "leak_to_outside": value * (1 + 0.01 * rng.standard_normal()),
                    "leak_to_outside_std": 0.01 * value,
                    "leak_to_outside_determined": True,
                }
            )
    table = tmp_path / "car.parquet"
    pq.write_table(pa.Table.from_pylist(rows), table)
    status, out, err = drs_bag("trend", table, "--json")
    assert status == 1, out + err
    front, rear = json.loads(out)
    assert (front["node"], front["drift"], front["runs"]) == (
        "/car7/front/drs_front",
        "rising",
        RUNS,
    )
    assert front["detected_bag"].startswith("runs/drs_front_")
    assert (rear["node"], rear["drift"], rear["runs"]) == ("/car7/rear/drs_rear", "none", RUNS)
    status, out, err = drs_bag("trend", table, "--node", "drs_rear")
    assert status == 0, out + err
    assert out.startswith("leak_to_outside of /car7/rear/drs_rear: 40 runs")
    assert "drift: none" in out


def test_a_drift_from_run_28_is_reported_with_its_onset_and_its_flag(tmp_path):
    """A table of forty runs whose value steps 2 standard deviations a run from run 28: the
    text and the JSON name the bag the drift began with and the bag it was flagged at (by run
    31), and the exit status says a drift."""
    require_rclpy()
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    rng = np.random.default_rng(28)
    values = 2.0 + 0.01 * rng.standard_normal(RUNS)
    values[27:] += 0.02 * np.arange(1, RUNS - 26)
    rows = [
        {
            "bag": f"runs/run_{k + 1:02d}",
            "node": "/drs",
            "start_ns": k * DAY_NS,
            "m_wing": values[k],
            "m_wing_std": 0.01,
            "m_wing_determined": True,
        }
        for k in range(RUNS)
    ]
    table = tmp_path / "season.parquet"
    pq.write_table(pa.Table.from_pylist(rows), table)
    status, out, err = drs_bag("trend", table, "--json")
    assert status == 1, out + err
    (row,) = json.loads(out)
    assert row["drift"] == "rising" and 27 <= row["onset_run"] <= 29
    assert 28 <= row["detected_run"] <= 31
    assert row["onset_bag"] == f"runs/run_{row['onset_run']:02d}"
    assert row["detected_bag"] == f"runs/run_{row['detected_run']:02d}"
    status, out, err = drs_bag("trend", table)
    assert status == 1, out + err
    assert (
        f"drift: rising, from run {row['onset_run']} ({row['onset_bag']}), significant at "
        f"run {row['detected_run']} ({row['detected_bag']})"
    ) in out
    status, out, err = drs_bag("trend", table, "--decision", "1000")
    assert status == 0 and "drift: none" in out, out + err
