"""The trajectory built one segment at a time: the reference of the plan tests."""

from __future__ import annotations

from drs_model.profile import QuinticSegment


def scalar_segments(times, strokes, rates, s0, v0=0.0, a0=0.0):
    """The trajectory built one QuinticSegment at a time from the boundary conditions (the
    construction ActuatorSim used before plans), the rates derived as the slope across the
    neighbours when not given."""
    t = [0.0, *times]
    s = [s0, *strokes]
    n = len(times)
    if rates is None:
        rates = [(s[k + 2] - s[k]) / (t[k + 2] - t[k]) for k in range(n - 1)] + [0.0]
    v = [v0, *rates]
    return [
        QuinticSegment.between(
            t[k], t[k + 1] - t[k], s[k], s[k + 1], v[k], v[k + 1], a0 if k == 0 else 0.0, 0.0
        )
        for k in range(n)
    ]
