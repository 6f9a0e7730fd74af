"""drs-demo deletes only what a demo run made: a plain --name, and a previous run's bag directory
and .rrd replaced only if they are what a run writes. The refusals happen before any DDS starts
(the whole demo runs in conftest's ``node_bag`` fixture)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from node_support import domain_for, node_env


def run_demo(tmp_path: Path, request, *args: str) -> subprocess.CompletedProcess:
    env = node_env(tmp_path / "env", domain_for(request.node.nodeid))
    return subprocess.run(
        [sys.executable, "-m", "drs_ros.demo", "--domain", env["ROS_DOMAIN_ID"], *args],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every path under ``root`` (but the subprocess's log folder): file bytes, None for dirs."""
    return {
        str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes())
        for p in sorted(root.rglob("*"))
        if "env" not in p.relative_to(root).parts
    }


def assert_refused(res: subprocess.CompletedProcess, words: str) -> None:
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert res.returncode == 2, (res.stdout[-2000:], res.stderr[-2000:])
    assert len(lines) == 1 and lines[0].startswith("drs-demo: error: "), res.stderr
    assert words in lines[0] and "Traceback" not in res.stderr, lines[0]
    assert "starting drs-node" not in res.stdout


@pytest.mark.parametrize("name", ["..", ".", "", "a/b", "../outside", "/abs", "-x"])
def test_name_must_be_a_plain_name(name, tmp_path, request):
    """``--name ..`` made OUT/.. (here tmp_path, the sentinel's folder) the bag to delete."""
    out = tmp_path / "out"
    (out / "a" / "b").mkdir(parents=True)
    (out / "a" / "b" / "keep.txt").write_text("not the demo's")
    (out / "keep.txt").write_text("not the demo's")
    (tmp_path / "sentinel.txt").write_text("not the demo's")
    before = snapshot(tmp_path)
    res = run_demo(tmp_path, request, "--out", str(out), f"--name={name}")
    assert_refused(res, "--name must be a plain name")
    assert repr(name) in res.stderr
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("case", ["extra_file", "a_file", "subfolder", "rrd_is_a_folder"])
def test_what_a_run_did_not_make_is_not_replaced(case, tmp_path, request):
    out = tmp_path / "out"
    out.mkdir()
    bag = out / "run"
    if case == "a_file":
        bag.write_text("my notes")
    elif case == "rrd_is_a_folder":
        (out / "run.rrd").mkdir()
        (out / "run.rrd" / "inside.txt").write_text("mine")
    else:
        bag.mkdir()
        (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
        (bag / "run_0.mcap").write_bytes(b"an earlier run")
        if case == "extra_file":
            (bag / "notes.txt").write_text("my notes")
        else:
            (bag / "sub").mkdir()
    before = snapshot(tmp_path)
    res = run_demo(tmp_path, request, "--out", str(out), "--name", "run")
    assert_refused(res, "not replacing it")
    assert snapshot(tmp_path) == before


def test_a_previous_run_is_removed_and_nothing_else(tmp_path):
    from drs_ros.demo import DemoError, remove_previous_run

    bag, rrd = tmp_path / "demo", tmp_path / "demo.rrd"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("x")
    (bag / "demo_0.mcap").write_bytes(b"x")
    rrd.write_bytes(b"x")
    (tmp_path / "demo_notes.txt").write_text("mine")
    remove_previous_run(bag, rrd)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo_notes.txt"]
    remove_previous_run(bag, rrd)  # nothing there: nothing to do
    # a link to a bag directory is not a bag directory the demo made
    target = tmp_path / "elsewhere"
    target.mkdir()
    (target / "demo_0.mcap").write_bytes(b"x")
    bag.symlink_to(target)
    with pytest.raises(DemoError, match="not a bag directory"):
        remove_previous_run(bag, rrd)
    assert (target / "demo_0.mcap").exists()


@pytest.mark.parametrize("name", ["demo", "run-2", "a.b", "..x"])
def test_plain_names_are_accepted(name):
    from drs_ros.demo import check_name

    assert check_name(name) == name
