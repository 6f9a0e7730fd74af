"""Where the command lines write (docs/cli.md): an output path in a directory that does not
exist, or of the wrong kind, is a usage error (status 2, argparse's line naming the option)
before anything runs, and nothing is created; a reader that went away (``drs limits | head -1``)
ends the command with status 0 and nothing on stderr."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
from pathlib import Path

import pytest
from ros_support import require_rclpy

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"

#: (tool, argv, the option named): ``{missing}`` is a directory that does not exist, ``{dir}``
#: the test's own (empty) directory.
BAD_OUTPUTS = [
    ("drs", ["draw", "--out", "{missing}/x.png"], "--out"),
    ("drs", ["draw", "--out", "{dir}/x.txt"], "--out"),
    ("drs", ["excite", "m_wing", "-o", "{missing}/goal.yaml"], "-o/--output"),
    ("drs", ["excite", "m_wing", "-o", "{dir}/goal.txt"], "-o/--output"),
    ("drs", ["excite", "m_wing", "--plot", "{missing}/e.png"], "--plot"),
    ("drs", ["fidelity", "--plot", "{missing}/f.png"], "--plot"),
    ("drs", ["fidelity", "--plot", "{dir}/f.svg"], "--plot"),
    ("drs", ["study", "spec.toml", "-o", "{missing}/study"], "-o/--output"),
    ("drs", ["coriolis", "collar", "--plot", "{missing}/plots"], "--plot"),
    ("drs-bag", ["recover", str(EXAMPLE), "-o", "{missing}/out"], "-o/--output"),
    ("drs-bag", ["merge", str(EXAMPLE), "other", "-o", "{missing}/out"], "-o/--output"),
    ("drs-bag", ["resimulate", str(EXAMPLE), "-o", "{missing}/out"], "-o/--output"),
    ("drs-bag", ["from-goal", "goal.yaml", "-o", "{missing}/out"], "-o/--output"),
    ("drs-bag", ["index", str(EXAMPLE), "-o", "{missing}/c.parquet"], "-o/--output"),
    ("drs-bag", ["check", str(EXAMPLE), "other", "-o", "{missing}/t.parquet"], "-o/--output"),
    (
        "drs-bag",
        ["fit", str(EXAMPLE), "--params", "m_wing", "-o", "{missing}/f.json"],
        "-o/--output",
    ),
    ("drs-bag", ["fit", str(EXAMPLE), "--params", "m_wing", "--plot", "{missing}/f.png"], "--plot"),
    ("drs-bag", ["trend", "season.parquet", "--plot", "{dir}/t.svg"], "--plot"),
    ("drs-demo", ["--out", "{missing}/bags"], "--out"),
]


def _main(tool: str):
    if tool == "drs":
        from drs_model.cli import main
    elif tool == "drs-bag":
        require_rclpy()
        from drs_ros.bag.cli import main
    else:
        require_rclpy()
        from drs_ros.demo import main
    return main


@pytest.mark.parametrize(
    ("tool", "argv", "option"),
    BAD_OUTPUTS,
    ids=[
        " ".join([t, *a[:1], o]) + (" ext" if "{dir}" in " ".join(a) else " dir")
        for t, a, o in BAD_OUTPUTS
    ],
)
def test_a_bad_output_path_is_status_2_and_creates_nothing(
    tmp_path, monkeypatch, tool, argv, option
):
    main = _main(tool)
    monkeypatch.chdir(tmp_path)
    args = [a.format(missing=tmp_path / "no" / "such", dir=tmp_path) for a in argv]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), pytest.raises(SystemExit) as stop:
        main(args)
    assert stop.value.code == 2, err.getvalue()
    last = err.getvalue().strip().splitlines()[-1]
    assert f"error: argument {option}: " in last, err.getvalue()
    assert "Traceback" not in err.getvalue()
    assert list(tmp_path.iterdir()) == []


#: name -> the command (``python -m``: the console scripts' mains) whose standard output is a
#: pipe nobody reads.
PIPED = {
    "drs limits": ["drs_model.cli", "limits"],
    "drs kinematics --json": ["drs_model.cli", "kinematics", "--stroke", "0.01", "--json"],
    "drs-bag info": ["drs_ros.bag.cli", "info", str(EXAMPLE)],
    "drs-bag check": ["drs_ros.bag.cli", "check", str(EXAMPLE)],
    "drs-bag recover": ["drs_ros.bag.cli", "recover", str(EXAMPLE), "-o", "{dir}/copy"],
    "drs-bag index": ["drs_ros.bag.cli", "index", str(EXAMPLE), "-o", "{dir}/c.parquet"],
}


@pytest.fixture(scope="module")
def piped_runs(tmp_path_factory) -> dict[str, subprocess.CompletedProcess]:
    """Every command of :data:`PIPED` at once (two at a time: the machine's cores), each
    writing into a pipe whose read end is closed before it starts (so every write meets
    EPIPE, as after ``head -1`` exits)."""
    require_rclpy()
    runs: dict[str, subprocess.CompletedProcess] = {}
    names = list(PIPED)
    for first in range(0, len(names), 2):
        started = {}
        for name in names[first : first + 2]:
            where = tmp_path_factory.mktemp("piped")
            read_end, write_end = os.pipe()
            os.close(read_end)
            args = [a.format(dir=where) for a in PIPED[name]]
            proc = subprocess.Popen(
                [sys.executable, "-m", *args], stdout=write_end, stderr=subprocess.PIPE, text=True
            )
            os.close(write_end)
            started[name] = proc
        for name, proc in started.items():
            _, err = proc.communicate(timeout=300)
            runs[name] = subprocess.CompletedProcess(proc.args, proc.returncode, "", err)
    return runs


@pytest.mark.parametrize("name", list(PIPED))
def test_a_reader_gone_is_status_0_and_nothing_on_stderr(piped_runs, name):
    res = piped_runs[name]
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""
