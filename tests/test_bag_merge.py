"""``drs-bag merge``: what it refuses, with one line and exit status 2, leaving no OUT; and a
merge of two bags of no common node keeps every record (the bag of two drs nodes, recorded by
two node processes, is tests/test_bag_nodes.py's)."""

from __future__ import annotations

from pathlib import Path

import pytest
from bag_support import copy_bags
from ros_support import require_rclpy

from drs_ros.bag.cli import main

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"


def _refused(capsys, *args) -> str:
    assert main(["merge", *map(str, args)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("drs-bag merge: error: "), err
    return err[0]


def test_what_merge_refuses(tmp_path, capsys):
    require_rclpy()
    out = tmp_path / "out"
    assert "two bags or more, got 1" in _refused(capsys, EXAMPLE, "-o", out)
    assert "are the same bag" in _refused(capsys, EXAMPLE, EXAMPLE / ".", "-o", out)
    twin = copy_bags([EXAMPLE], tmp_path / "twin")
    line = _refused(capsys, EXAMPLE, twin, "-o", out)
    assert "the drs node /drs is in" in line and str(twin) in line
    # a topic of another type in the other bag
    other = copy_bags(
        [EXAMPLE],
        tmp_path / "other",
        leave_out=["/parameter_events", "/drs/markers"],
        rename={"/drs/flap_gap": "/drs/markers"},
    )
    line = _refused(capsys, EXAMPLE, other, "-o", out)
    assert "/drs/markers is visualization_msgs/msg/MarkerArray in" in line
    assert "than std_msgs/msg/Float64 in" in line
    cut = tmp_path / "cut"
    cut.mkdir()
    data = next(EXAMPLE.glob("*.mcap")).read_bytes()
    (cut / "cut_0.mcap").write_bytes(data[: len(data) // 2])
    assert "cut" in _refused(capsys, EXAMPLE, cut, "-o", out)
    assert not out.exists()
    out.mkdir()
    (out / "x").write_text("an earlier run")
    assert "already holds files" in _refused(capsys, EXAMPLE, tmp_path / "twin", "-o", out)


def test_two_bags_of_one_run_split_by_topic_merge_back_into_it(tmp_path, capsys):
    """The example split into two bags by topic (one holding its node's parameters and effect
    record, the other its signals) merges back into a bag that holds every record of it as it
    was and checks as it does. (It does not re-run: the node writes a tick's effect records
    before its states, logged a little later; interleaved by log time they come after. A merge
    keeps each bag's own order, so a node's records re-run when they are in one bag.)"""
    require_rclpy()
    from drs_ros.bag.read.reader import scan

    signals = [
        "/joint_states",
        "/drs/piston_force",
        "/drs/flap_gap",
        "/drs/piston_acceleration",
        "/drs/joint_reactions",
        "/drs/markers",
        "/diagnostics",
    ]
    rest = [t for t in scan(EXAMPLE).counts if t not in signals]
    a = copy_bags([EXAMPLE], tmp_path / "a", leave_out=signals)
    b = copy_bags([EXAMPLE], tmp_path / "b", leave_out=rest)
    assert main(["merge", str(a), str(b), "-o", str(tmp_path / "ab")]) == 0
    capsys.readouterr()

    def records(bag):
        out = []
        scan(bag, lambda m: out.append((m.topic, m.log_time, m.publish_time, m.sequence, m.data)))
        return out

    assert sorted(records(tmp_path / "ab")) == sorted(records(EXAMPLE))
    assert main(["check", str(tmp_path / "ab")]) == 0


def test_a_sqlite3_bag_merges_with_an_mcap_bag(tmp_path, capsys):
    """A sqlite3 bag (rosbags' writer) and an MCAP bag of no drs node (the example's records
    on other topics): every record of both,
    each bag's in its own order; the result checks."""
    require_rclpy()
    from ros_support import mcap_to_db3

    from drs_ros.bag.read.reader import scan

    db3 = mcap_to_db3(EXAMPLE, tmp_path / "db3")
    topics = [t for t in scan(EXAMPLE).counts if t != "/parameter_events"]
    other = copy_bags(
        [EXAMPLE],
        tmp_path / "other",
        leave_out=["/parameter_events"],
        rename={t: "/other" + t for t in topics},
    )
    assert main(["merge", str(db3), str(other), "-o", str(tmp_path / "both")]) == 0
    assert "db3: 8517 messages" in capsys.readouterr().out

    def records(bag):
        out = []
        scan(bag, lambda m: out.append((m.topic, m.log_time, m.sequence, m.data)))
        return out

    merged, sources = records(tmp_path / "both"), [records(db3), records(other)]
    assert sorted(merged) == sorted(sources[0] + sources[1])
    for source in sources:
        mine = set(source)
        assert [r for r in merged if r in mine] == source
    assert main(["check", str(tmp_path / "both")]) == 0
