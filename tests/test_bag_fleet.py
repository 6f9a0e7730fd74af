"""drs-bag check and resimulate over a fleet of bags on a real Dask LocalCluster: one row per bag
(good, damaged, split, sqlite3, a fresh node recording), the damaged one carrying its error, the
same table from 2 workers as from 1; one bag keeps its single-bag output."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from ros_support import mcap_to_db3, require_module, require_rclpy, write_split_bag

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory, node_bag):
    """A season in miniature: runs/<day>/<bag>, of every kind the tools read."""
    require_rclpy()
    from drs_model.params import DRSParams

    root = tmp_path_factory.mktemp("season")
    day1, day2 = root / "runs" / "day1", root / "runs" / "day2"
    day1.mkdir(parents=True)
    day2.mkdir(parents=True)
    shutil.copytree(EXAMPLE, day1 / "example")
    shutil.copytree(node_bag, day1 / "node")
    damaged = day2 / "damaged"
    shutil.copytree(EXAMPLE, damaged)
    mcap = next(damaged.glob("*.mcap"))
    mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])  # cut: truncated
    split, _ = write_split_bag(tmp_path_factory.mktemp("split"), DRSParams(), killed=False)
    shutil.copytree(split, day2 / "split")
    mcap_to_db3(EXAMPLE, day2 / "sqlite")
    (root / "notes.txt").write_text("not a bag")
    return root


def _table(path: Path) -> list[dict]:
    import pyarrow.parquet as pq

    return pq.read_table(path).to_pylist()


def test_find_bags_searches_directories_and_globs(fleet_dir):
    from drs_ros.bag.season.fleet import FleetError, find_bags

    names = [p.name for p in find_bags([str(fleet_dir)])]
    assert names == ["example", "node", "damaged", "split", "sqlite"]
    glob = str(fleet_dir / "runs" / "*" / "s*")
    assert [p.name for p in find_bags([glob])] == ["split", "sqlite"]
    listed = [str(fleet_dir / "runs" / "day1" / "example"), str(fleet_dir / "runs" / "day1")]
    assert [p.name for p in find_bags(listed)] == ["example", "node"]  # each bag once
    with pytest.raises(FleetError, match="matches no file"):
        find_bags([str(fleet_dir / "nothing*")])


def test_two_workers_check_a_directory_of_bags_as_one_does(fleet_dir, tmp_path, capsys):
    require_module("pyarrow")
    from drs_ros.bag.check import command as check

    status_2 = check.main([str(fleet_dir), "--jobs", "2", "-o", str(tmp_path / "two.parquet")])
    out = capsys.readouterr().out
    status_1 = check.main([str(fleet_dir), "--jobs", "1", "-o", str(tmp_path / "one.parquet")])
    assert status_2 == status_1 == 1  # the damaged bag did not pass
    two, one = _table(tmp_path / "two.parquet"), _table(tmp_path / "one.parquet")
    by_name = {Path(r["bag"]).name: r for r in two}
    assert list(by_name) == ["example", "node", "damaged", "split", "sqlite"]  # one row each
    assert "5 bags: 4 PASS, 1 UNREADABLE" in out and "truncated" in out
    bad = by_name["damaged"]
    assert bad["verdict"] == "UNREADABLE" and bad["exit_status"] == 2
    assert "truncated" in bad["error"] and bad["messages"] is None
    for name in ("example", "node", "split", "sqlite"):
        row = by_name[name]
        assert row["verdict"] == "PASS" and row["error"] is None, row
        assert row["messages"] == sum(n for _topic, n in row["counts"])  # a map: (key, value)
        assert row["loop_constraint_m"] < 1e-9 and row["loop_constraint_m_status"] == "ok"
    assert by_name["split"]["messages"] == 720 and by_name["split"]["storage"] == "mcap"
    assert by_name["sqlite"]["storage"] == "sqlite3"
    # the sqlite3 copy of the example is the example
    for column in (
        "loop_constraint_m",
        "gap_vs_model_m",
        "piston_force_vs_model_n",
        "peak_force_n",
        "largest_gap_m",
        "refused_commands",
        "missed_deadlines",
    ):
        assert by_name["sqlite"][column] == by_name["example"][column], column
    # the run's figures, from an independent reading of the example bag (mcap's reader)
    assert by_name["example"]["peak_force_n"] == pytest.approx(_peak_force(EXAMPLE), abs=0)
    assert by_name["example"]["refused_commands"] >= 1  # the demo's NaN stroke
    assert by_name["example"]["param_m_wing"] == 2.0
    # 2 workers give the table 1 worker gives (but the tasks' wall times)
    for a, b in zip(two, one, strict=True):
        a.pop("task_s"), b.pop("task_s")
        assert a.keys() == b.keys()
        for key in a:
            if isinstance(a[key], float):
                np.testing.assert_equal(a[key], b[key])
            else:
                assert a[key] == b[key], key


def _peak_force(bag: Path) -> float:
    """Largest |effort[0]| of /joint_states, decoded by mcap_ros2 (not by drs)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(next(bag.glob("*.mcap")), "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        forces = [
            abs(m.effort[0])
            for _s, _c, _m, m in reader.iter_decoded_messages(topics=["/joint_states"])
        ]
    return max(forces)


def test_resimulate_a_fleet_gives_one_row_per_bag(fleet_dir, tmp_path, capsys):
    from drs_ros.bag.cli import main

    day1 = fleet_dir / "runs" / "day1"
    table = tmp_path / "resim.parquet"
    glob = str(day1 / "*")
    assert (
        main(
            [
                "resimulate",
                glob,
                str(fleet_dir / "runs" / "day2" / "damaged"),
                "--jobs",
                "2",
                "-o",
                str(table),
            ]
        )
        == 1
    )
    rows = {Path(r["bag"]).name: r for r in _table(table)}
    assert list(rows) == ["example", "node", "damaged"]
    assert rows["node"]["verdict"] == "PASS" and rows["node"]["stroke_deviation_m"] == 0.0
    assert rows["example"]["verdict"] == "PASS"
    assert rows["damaged"]["verdict"] == "UNREADABLE" and "truncated" in rows["damaged"]["error"]
    capsys.readouterr()


def test_a_bad_table_path_or_no_bag_is_one_line_and_status_2(fleet_dir, tmp_path, capsys):
    from drs_ros.bag.check import command as check

    assert check.main([str(fleet_dir), "-o", str(tmp_path / "table.csv")]) == 2
    assert "names the table, a .parquet file" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert check.main([str(empty), "--jobs", "1"]) == 2
    assert "no bag under" in capsys.readouterr().err


def test_index_catalogues_from_summaries_what_check_reads_from_every_byte(
    fleet_dir, tmp_path, capsys
):
    """The catalogue's columns equal the check table's for every readable bag (the same counts,
    start and duration, from metadata.yaml or the MCAP summary or the sqlite3 tables instead of
    every message); an unfinished recording without a summary is a row with its error; DuckDB
    queries the file."""
    duckdb = require_module("duckdb")
    from drs_ros.bag.check import command as check
    from drs_ros.bag.cli import main

    root = tmp_path / "season"  # the module's directory, and two bags more
    shutil.copytree(fleet_dir, root)
    (root / "bare").mkdir()
    shutil.copy(next(EXAMPLE.glob("*.mcap")), root / "bare" / "bare_0.mcap")  # no metadata.yaml
    (root / "unfinished").mkdir()
    data = next(EXAMPLE.glob("*.mcap")).read_bytes()
    (root / "unfinished" / "unfinished_0.mcap").write_bytes(data[: len(data) // 2])
    catalogue = tmp_path / "catalogue.parquet"
    assert main(["index", str(root), "-o", str(catalogue)]) == 1  # one row has an error
    assert "catalogued 7 bags" in capsys.readouterr().out
    assert check.main([str(root), "--jobs", "2", "-o", str(tmp_path / "t.parquet")]) == 1
    capsys.readouterr()
    rows = {Path(r["bag"]).name: r for r in _table(catalogue)}
    checked = {Path(r["bag"]).name: r for r in _table(tmp_path / "t.parquet")}
    assert list(rows) == list(checked)
    assert rows["bare"]["source"] == "MCAP summary" and rows["sqlite"]["storage"] == "sqlite3"
    assert "no readable MCAP summary" in rows["unfinished"]["error"]
    for name, row in rows.items():
        if checked[name]["error"] is None:
            for column in ("storage", "messages", "start_ns", "duration_s"):
                assert row[column] == checked[name][column], (name, column)
            assert sorted(row["counts"]) == sorted(checked[name]["counts"]), name
    # the summary of the truncated copy still says what its metadata.yaml says: the index
    # is no check
    assert rows["damaged"]["error"] is None and checked["damaged"]["verdict"] == "UNREADABLE"
    query = (
        f"SELECT storage, count(*) AS bags, sum(counts['/joint_states']) AS joint_states "
        f"FROM '{catalogue}' WHERE error IS NULL GROUP BY storage ORDER BY storage"
    )
    got = duckdb.sql(query).fetchall()
    want: dict[str, list] = {}
    for row in rows.values():
        if row["error"] is None:
            entry = want.setdefault(row["storage"], [0, 0])
            entry[0] += 1
            entry[1] += dict(row["counts"]).get("/joint_states", 0)
    assert got == [(k, *v) for k, v in sorted(want.items())]


def test_a_season_with_links_gives_each_bag_once(tmp_path, capsys):
    """A season as it is kept: days of runs, ``latest`` linked to the last day, a link back up to
    the season, a run linked from another day. Each bag once, under its real path, whether the
    season is walked (check, index, resimulate) or globbed with ``**``."""
    require_rclpy()
    from drs_ros.bag.cli import main
    from drs_ros.bag.season.fleet import find_bags

    season = tmp_path / "season"
    for day, runs in (("day1", ("run1", "run2")), ("day2", ("run3",))):
        for run in runs:
            shutil.copytree(EXAMPLE, season / day / run)
    (season / "latest").symlink_to("day2")
    (season / "day2" / "season").symlink_to("..")  # back up into itself
    (season / "day2" / "best").symlink_to(season / "day1" / "run2")  # a bag by a second path
    real = ["day1/run1", "day1/run2", "day2/run3"]
    for spec in (season, season / "**" / "metadata.yaml", season / "*" / "*"):
        found = find_bags([str(spec)])
        assert [p.relative_to(season).as_posix() for p in found] == real, spec
    assert main(["index", str(season), "-o", str(tmp_path / "catalogue.parquet")]) == 0
    assert "catalogued 3 bags" in capsys.readouterr().out
    for verb in ("check", "resimulate"):
        table = tmp_path / f"{verb}.parquet"
        assert main([verb, str(season), "--jobs", "1", "-o", str(table)]) == 0
        rows = _table(table)
        assert [Path(r["bag"]).relative_to(season).as_posix() for r in rows] == real
        assert {(r["node"], r["verdict"]) for r in rows} == {("/drs", "PASS")}
    assert "3 bags: 3 PASS" in capsys.readouterr().out
