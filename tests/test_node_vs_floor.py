"""``benchmarks/node_vs_floor.py``'s listener stop: a listener that misses its first SIGINT (as
one did under rclpy's spin, 2026-11-29, which ended a 10-minute run on a timeout) is asked
again and its counts kept; one that ignores every SIGINT is killed, and the run goes on."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import node_vs_floor  # noqa: E402

#: A listener's stand-in: ready at once, then it ends with its counts at its ``n``-th SIGINT.
LISTENER = """
import json, signal, sys, time
n, seen = int(sys.argv[1]), []
signal.signal(signal.SIGINT, lambda *_: seen.append(1))
print(json.dumps({"ready": ["/joint_states"]}), flush=True)
while len(seen) < n:
    time.sleep(0.01)
print(json.dumps({"received": {"/joint_states": 42}}), flush=True)
"""


def _listener(sigints_needed: int) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-c", LISTENER, str(sigints_needed)], stdout=subprocess.PIPE, text=True
    )
    assert "ready" in proc.stdout.readline()
    return proc


def test_a_listener_that_misses_its_first_sigint_is_asked_again(monkeypatch):
    monkeypatch.setattr(node_vs_floor, "LISTENER_STOP_WAITS_S", (0.5, 30.0))
    proc = _listener(2)
    assert node_vs_floor.stop_listener(proc) == {"/joint_states": 42}
    assert proc.returncode == 0


def test_a_listener_that_ignores_every_sigint_is_killed_and_its_counts_are_lost(monkeypatch):
    monkeypatch.setattr(node_vs_floor, "LISTENER_STOP_WAITS_S", (0.3, 0.3))
    proc = _listener(1_000)
    t0 = time.monotonic()
    assert node_vs_floor.stop_listener(proc) == {}
    assert proc.returncode is not None and proc.returncode < 0  # killed
    assert time.monotonic() - t0 < 20.0
