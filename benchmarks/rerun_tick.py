"""What the rerun recording costs a 1 kHz deadline loop: the batch sent by the recorder's sender
thread against the same batch sent in the loop's own thread.

A thread sleeps to absolute deadlines every ``1/--rate_hz`` s (under SCHED_FIFO when the
process may, as the node's tick; CPython's switch interval as the node sets it) and at each
deadline logs one state of the seed manoeuvre into a :class:`RerunRecorder` (batch: one second
of states, as the node does), in interleaved blocks of ``--seconds``:

* ``none``: the loop logs nothing (the floor: the machine's own lateness);
* ``sender``: ``log_state`` only (the batch goes to the sender thread);
* ``in_loop``: ``log_state``, then, when a batch was handed off, ``flush()`` in the loop: the loop
  waits for the send, as when the batch was sent in the tick.

Per block: the lateness of the wake-ups (median, p99, max [us]), the deadlines missed (a wake-up
later than half a period: a tick later than 1.5 periods) and the longest ``log_state`` (+ flush)
call [us]. Medians over ``--rounds`` blocks of each kind. Results to
``benchmarks/results/rerun_tick.json``.

Usage: ``python benchmarks/rerun_tick.py [--rate_hz 1000] [--seconds 5] [--rounds 3]``
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from drs_model.kinematics import kinematic_state
from drs_model.params import DRSParams
from drs_model.profile import drs_manoeuvre
from drs_ros.node.runner import GIL_SWITCH_INTERVAL_S
from drs_ros.node.tick_schedule import apply_tick_policy, leave_tick_policy
from drs_ros.recording.rerun_recorder import RerunRecorder

KINDS = ("none", "sender", "in_loop")


def manoeuvre_q(params: DRSParams, n: int = 500) -> np.ndarray:
    man = drs_manoeuvre(params)
    s, v, a = man.evaluate(np.linspace(0.0, man.t_end, n))
    return kinematic_state(s, v, a, params).q


def run_block(kind: str, rate_hz: float, seconds: float, q: np.ndarray, out: Path) -> dict:
    """One block of the deadline loop in its own thread; its figures."""
    period_ns = round(1e9 / rate_hz)
    n = round(seconds * rate_hz)
    rec = None if kind == "none" else RerunRecorder(out, batch=round(rate_hz))
    late_ns = np.zeros(n, dtype=np.int64)
    call_ns = np.zeros(n, dtype=np.int64)
    policy = {}

    def loop():
        policy["p"] = apply_tick_policy("fifo", 10)
        deadline = time.monotonic_ns()
        try:
            for k in range(n):
                deadline += period_ns
                while (wait := deadline - time.monotonic_ns()) > 0:
                    time.sleep(wait * 1e-9)
                late_ns[k] = -wait
                t0 = time.perf_counter_ns()
                if rec is not None:
                    rec.log_state(k / rate_hz, q[k % len(q)], 100.0)
                    if kind == "in_loop" and rec.sample_count + rec.batch <= k + 1:
                        rec.flush()  # the send waited for here, as in the tick before
                call_ns[k] = time.perf_counter_ns() - t0
        finally:
            leave_tick_policy(policy["p"])

    th = threading.Thread(target=loop, name="tick")
    th.start()
    th.join()
    if rec is not None:
        rec.close()
    late_us = late_ns / 1e3
    return {
        "policy": policy["p"].name,
        "late_median_us": float(np.median(late_us)),
        "late_p99_us": float(np.percentile(late_us, 99)),
        "late_max_us": float(late_us.max()),
        "missed": int(np.sum(late_ns > period_ns // 2)),
        "ticks": n,
        "call_max_us": float(call_ns.max() / 1e3),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate_hz", type=float, default=1000.0)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
    q = manoeuvre_q(DRSParams())
    blocks = {k: [] for k in KINDS}
    with tempfile.TemporaryDirectory(prefix="drs-rerun-tick-") as tmp:
        for r in range(args.rounds):
            for kind in KINDS:  # interleaved: the machine's load falls on every kind alike
                fig = run_block(kind, args.rate_hz, args.seconds, q, Path(tmp) / f"{kind}{r}.rrd")
                blocks[kind].append(fig)
                print(kind, fig, flush=True)
    summary = {
        kind: {
            key: statistics.median(b[key] for b in blocks[kind])
            for key in blocks[kind][0]
            if key != "policy"
        }
        | {"policy": blocks[kind][0]["policy"]}
        for kind in KINDS
    }
    print(json.dumps(summary, indent=1))
    out = Path(__file__).with_name("results") / "rerun_tick.json"
    out.write_text(
        json.dumps({"args": vars(args), "median": summary, "blocks": blocks}, indent=1) + "\n"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
