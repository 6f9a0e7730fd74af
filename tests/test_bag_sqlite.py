"""rosbag2's sqlite3 storage (.db3): a bag that rosbags writes (the example bag copied into it)
reads in drs-bag info, check and resimulate with the same results as the MCAP it came from, and a
damaged database is one line and exit status 2."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from ros_support import mcap_to_db3, require_rclpy

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"


def drs_bag(*args) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def db3_bag(tmp_path_factory):
    require_rclpy()
    return mcap_to_db3(EXAMPLE, tmp_path_factory.mktemp("sqlite") / "example_db3")


def test_rosbags_wrote_a_sqlite3_bag(db3_bag):
    assert [p.suffix for p in db3_bag.iterdir() if p.suffix != ".yaml"] == [".db3"]
    assert "storage_identifier: sqlite3" in (db3_bag / "metadata.yaml").read_text()


def test_check_of_the_sqlite3_copy_equals_the_check_of_the_mcap(db3_bag):
    mcap, db3 = drs_bag("check", str(EXAMPLE), "--json"), drs_bag("check", str(db3_bag), "--json")
    assert mcap.returncode == db3.returncode == 0, db3.stderr
    a, b = json.loads(mcap.stdout), json.loads(db3.stdout)
    assert b["messages"] == a["messages"] and b["checks"] == a["checks"]
    assert b["notes"][1:] == a["notes"][1:]  # the recorded parameters found
    # every byte verified, each by its storage's own checks
    assert a["notes"][0].endswith("(CRCs, summary, metadata.yaml, exact CDR)")
    assert b["notes"][0].endswith("(SQLite integrity check, metadata.yaml, exact CDR)")


def test_info_reads_the_sqlite3_bag_and_a_bare_db3_file(db3_bag):
    mcap = json.loads(drs_bag("info", str(EXAMPLE), "--json").stdout)
    for path in (db3_bag, next(db3_bag.glob("*.db3"))):
        res = drs_bag("info", str(path), "--json")
        assert res.returncode == 0, res.stderr
        info = json.loads(res.stdout)
        assert info["storage"] == "sqlite3"
        assert sorted(t[:3] for t in info["topics"]) == sorted(t[:3] for t in mcap["topics"])
        assert info["start_ns"] == mcap["start_ns"] and info["duration_ns"] == mcap["duration_ns"]


def test_resimulate_of_the_sqlite3_copy_equals_the_mcap(db3_bag):
    """The rows are read in the order rosbag2 wrote them (a clock record before the states of
    its tick), not sorted by time: the re-run matches each state to its clock origin."""
    mcap = drs_bag("resimulate", str(EXAMPLE), "--json")
    db3 = drs_bag("resimulate", str(db3_bag), "--json")
    assert mcap.returncode == db3.returncode == 0, db3.stderr
    assert json.loads(db3.stdout)["signals"] == json.loads(mcap.stdout)["signals"]


@pytest.mark.parametrize("damage", ["truncated", "overwritten", "not-sqlite"])
def test_a_damaged_database_is_one_line_and_status_2(db3_bag, tmp_path, damage):
    bag = tmp_path / "bad"
    shutil.copytree(db3_bag, bag)
    db = next(bag.glob("*.db3"))
    raw = bytearray(db.read_bytes())
    if damage == "truncated":
        raw = raw[: len(raw) // 2]
    elif damage == "overwritten":
        raw[len(raw) // 2 : len(raw) // 2 + 4096] = bytes(4096)
    else:
        raw = bytearray(b"not a database " * 200)
    db.write_bytes(bytes(raw))
    # info of a bag directory reads its metadata.yaml alone (as ros2 bag info); of a bare file,
    # the file
    runs = [("check", bag), ("info", db)] if damage != "overwritten" else [("check", bag)]
    for verb, path in runs:
        res = drs_bag(verb, str(path))
        assert res.returncode == 2, (verb, res.stdout[-2000:], res.stderr)
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
        assert str(db) in lines[0] or str(bag) in lines[0], lines
