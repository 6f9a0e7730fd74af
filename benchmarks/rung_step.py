"""Every rung stepped as the node steps it, side by side in one run (medians of interleaved
repeats; on a shared machine only the ratios mean much): ``advance(1)`` per physics step at
1 kHz and ``sample()`` per publish, through the seed's open (10 ms), a hold, and the close,
in wall seconds per simulated second; and the ratio ``rigid / kinematic`` (goal: >= 50x), next
to the floor of the loop itself (two empty method calls per step).

Usage: ``python benchmarks/rung_step.py [--repeat 7] [--seconds 1] [--publish-every 1]``.
"""

from __future__ import annotations

import argparse
import statistics
import time

from drs_model import DRSParams
from drs_model.fidelity import make_rung

P = DRSParams()
RUNGS = ("kinematic", "quasi-static", "rigid", "hydraulic")
DT = 1e-3  # physics step [s]: 1 kHz


def cost_per_second(name: str, seconds: float, publish_every: int) -> float:
    """Wall seconds per simulated second: open at 0, close at half time, ``advance(1)`` each
    step and ``sample()`` every ``publish_every`` steps."""
    rung = make_rung(name, P, DT)
    n = int(round(seconds / DT))
    half = n // 2
    clock = time.perf_counter()
    for k in range(n):
        if k == 0:
            rung.command_drs(True)
        elif k == half:
            rung.command_drs(False)
        rung.advance(1)
        if k % publish_every == 0:
            rung.sample()
    return (time.perf_counter() - clock) / seconds


class _Floor:
    """Two empty methods in the loop's place: what any Python rung pays per step to be called
    (``advance(1)`` and ``sample()``), the floor under every stepped figure."""

    def advance(self, n: int) -> None:
        pass

    def sample(self) -> None:
        pass


def floor_per_second(seconds: float, publish_every: int) -> float:
    """Wall seconds per simulated second of the same loop over :class:`_Floor`."""
    rung, n = _Floor(), int(round(seconds / DT))
    clock = time.perf_counter()
    for k in range(n):
        rung.advance(1)
        if k % publish_every == 0:
            rung.sample()
    return (time.perf_counter() - clock) / seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated seconds per run")
    ap.add_argument("--publish-every", type=int, default=1, help="physics steps per sample()")
    args = ap.parse_args()
    for name in RUNGS:  # warm-up: imports, numba dispatch
        cost_per_second(name, 0.05, 1)
    samples = {name: [] for name in (*RUNGS, "call floor")}
    for _ in range(args.repeat):  # interleaved: the same load on every rung
        for name in RUNGS:
            samples[name].append(cost_per_second(name, args.seconds, args.publish_every))
        samples["call floor"].append(floor_per_second(args.seconds, args.publish_every))
    costs = {k: statistics.median(v) for k, v in samples.items()}
    for name, cost in costs.items():
        print(
            f"{name:>13}: {cost * 1e3:8.3f} ms per simulated s "
            f"({cost * DT * 1e6:6.2f} us per step), "
            f"rigid / this = {costs['rigid'] / cost:6.1f}x"
        )
    ratio = costs["rigid"] / costs["kinematic"]
    print(
        f"goal: kinematic >= 50x cheaper than rigid stepped: {ratio:.1f}x "
        f"{'met' if ratio >= 50 else 'MISSED'}"
    )


if __name__ == "__main__":
    main()
