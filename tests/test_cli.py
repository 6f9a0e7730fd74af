"""The drs command line: JSON output, tables and error exits."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from drs_model import kinematics as kin
from drs_model.cli import main


def run_json(capsys, *argv):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_limits_json(capsys, params):
    d = run_json(capsys, "limits")
    s_min, s_max = kin.stroke_limits(params)
    assert d["s_min"] == s_min and d["s_max"] == s_max
    assert d["singular_strokes"][0] == pytest.approx(-0.001552857370, rel=5e-10)
    assert d["closed_to_dead_centre"] == pytest.approx(0.00175, abs=1e-5)


def test_kinematics_json(capsys, params):
    d = run_json(capsys, "kinematics", "--stroke", "0.01")
    q = kin.solve_position(0.01, params)
    assert [d["q"]["s"], d["q"]["psi1"], d["q"]["psi3"]] == pytest.approx(q.tolist(), abs=1e-15)
    assert set(d["points"]) >= {"B", "C", "T", "R", "G1", "G2", "G3", "P"}
    d2 = run_json(capsys, "kinematics", "--stroke", "0.01", "--branch", "2")
    assert d2["q"]["psi3"] != pytest.approx(d["q"]["psi3"])
    d3 = run_json(capsys, "kinematics", "--gap", "0.05")
    assert d3["gap"] == pytest.approx(0.05, abs=1e-15)
    d4 = run_json(capsys, "kinematics", "--flap-angle", str(d["q"]["psi3"]))
    assert d4["q"]["s"] == pytest.approx(0.01, abs=1e-14)


def test_profile_and_demo(capsys, params):
    d = run_json(capsys, "profile", "--time", "0,0.005,0.05")
    assert d["gap"] == pytest.approx([0.01, d["gap"][1], 0.01], abs=1e-12)
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "s_min (closed, gap 10 mm)" in out and "gap [mm]" in out


def test_set_override(capsys):
    base = run_json(capsys, "limits")
    # lifting the piston base by 1 mm leaves the gap rule's flap angles and shortens s by 1 mm
    moved = run_json(capsys, "limits", "--set", "y_A=0.001")
    assert moved["s_min"] == pytest.approx(base["s_min"] - 0.001, abs=1e-12)
    assert moved["psi3_closed"] == base["psi3_closed"]


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["kinematics", "--stroke", "0.5"], r"cannot close at stroke 0\.5 m"),
        (["kinematics", "--stroke", "nan"], r"stroke must be finite, got nan"),
        (["limits", "--set", "L2=-1"], r"L2 must be > 0 m"),
        (["profile", "--time", "inf"], r"time must be finite"),
    ],
)
def test_errors_exit_2_with_one_line(capsys, argv, match):
    import re

    assert main(argv) == 2
    err = capsys.readouterr().err
    assert re.search(match, err) and err.count("\n") == 1


def test_console_script_runs():
    out = subprocess.run(
        [sys.executable, "-m", "drs_model.cli", "limits", "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(out.stdout)["gap_open"] == 0.05


@pytest.mark.parametrize("out", ["x.txt", "no/such/dir/x.png"])
def test_draw_to_a_bad_path_exits_2_and_creates_nothing(tmp_path, out):
    res = subprocess.run(
        [sys.executable, "-m", "drs_model.cli", "draw", "--out", out],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert "drs draw: error: argument --out" in res.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_reader_gone_is_no_error():
    """``drs limits | head -1``: the reader went away before the output was written (the read
    end of the pipe closed first, so every write meets EPIPE): exit 0, nothing on stderr."""
    import os

    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        res = subprocess.run(
            [sys.executable, "-m", "drs_model.cli", "limits"],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
        )
    finally:
        os.close(write_end)
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""
