"""SIGINT and SIGTERM at any moment of a command line's life (drs_model.cli.start_signals,
docs/cli.md): during its imports, its start and its run, ``drs-node`` and ``drs-bag play`` end
with status 0, no traceback, and leave no bag or a bag that checks. The moments are drawn from a
seeded generator and each is named in the failure message;
``benchmarks/shutdown_stress.py --mode start-up`` runs many more."""

from __future__ import annotations

import contextlib
import io
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from node_support import domain_for, node_env

from drs_ros.node.command_line import node_command

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"

#: Signals per tool in the suite (the benchmark runs 50).
SIGNALS_PER_TOOL = 5
#: The moments are drawn from [0, LATEST_S] after the process starts [s]: drs-node's imports
#: and start take ~1-2.5 s, drs-bag play's ~1.5 s and the example bag plays for 3.5 s.
LATEST_S = 3.5


def _run_pair(work: Path, k: int, rng: random.Random, domain: int) -> list[dict]:
    """drs-node and drs-bag play started together, each signalled at its own drawn moment;
    returns what happened to each."""
    bag = work / f"node{k}"
    commands = {
        "drs-node": node_command({"bag_path": bag, "flush_period": 0.2}),
        "drs-bag play": [sys.executable, "-m", "drs_ros.bag.cli", "play", str(EXAMPLE)],
    }
    plan = {
        tool: (rng.uniform(0.0, LATEST_S), rng.choice((signal.SIGINT, signal.SIGTERM)))
        for tool in commands
    }
    env = node_env(work / "log", domain)
    t0 = time.monotonic()
    procs = {
        tool: subprocess.Popen(
            argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
        for tool, argv in commands.items()
    }
    sent_at = {}
    try:
        for tool, (at, sig) in sorted(plan.items(), key=lambda item: item[1][0]):
            time.sleep(max(0.0, t0 + at - time.monotonic()))  # the drawn moment itself
            if procs[tool].poll() is None:
                procs[tool].send_signal(sig)
                sent_at[tool] = time.monotonic()
        runs = []
        for tool, proc in procs.items():
            _, err = proc.communicate(timeout=60)  # a hang, not a slow stop
            after = time.monotonic() - sent_at[tool] if tool in sent_at else None
            at, sig = plan[tool]
            runs.append(
                {
                    "tool": tool,
                    "k": k,
                    "at_s": round(at, 3),
                    "signal": sig.name,
                    "sent": tool in sent_at,
                    "status": proc.returncode,
                    "ended_s_after": None if after is None else round(after, 2),
                    "stderr": err,
                }
            )
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
    runs[0]["bag"] = bag
    return runs


def _bag_verdict(bag: Path) -> str:
    """'' when no bag was made or it checks (status 0), else why not."""
    if not bag.exists():
        return ""
    from drs_ros.bag.cli import main as bag_main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = bag_main(["check", str(bag)])
    return "" if status == 0 else f"drs-bag check {bag.name}: status {status}: {err.getvalue()}"


def test_signals_at_random_moments_of_start_and_run(tmp_path, request):
    rng = random.Random(20261128)
    domain = domain_for(request.node.nodeid)
    runs = []
    for k in range(SIGNALS_PER_TOOL):
        runs += _run_pair(tmp_path, k, rng, domain)
    bad = []
    for run in runs:
        lines = run["stderr"].strip().splitlines()
        problem = []
        if run["status"] != 0:
            problem.append(f"status {run['status']}")
        if "Traceback" in run["stderr"]:
            problem.append("a traceback")
        if "bag" in run:
            verdict = _bag_verdict(run["bag"])
            if verdict:
                problem.append(verdict)
        if problem:
            last = lines[-1] if lines else ""
            bad.append(
                f"{run['tool']} #{run['k']}: {run['signal']} at {run['at_s']} s: "
                f"{', '.join(problem)}; last line {last!r}"
            )
    moments = [(r["tool"], r["signal"], r["at_s"], r["ended_s_after"]) for r in runs]
    assert not bad, "\n".join(bad) + f"\nevery (tool, signal, moment s, ended s after): {moments}"
    assert sum(r["sent"] for r in runs) >= len(runs) - 1, moments  # the signals met the tools
