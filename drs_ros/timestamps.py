"""drs_model's time conversions (:mod:`drs_model.timebase`: integer nanoseconds, ``(sec,
nanosec)``, seconds, steps), under the name the node and the bag tools import them by."""

from __future__ import annotations

from drs_model.timebase import (
    NS_PER_S,
    T0_NS,
    nearest_step,
    nearest_steps,
    ns_from_parts,
    ns_from_seconds,
    ns_of,
    seconds_from_ns,
    set_ns,
    split_ns,
    steps_within,
)

__all__ = [
    "T0_NS",
    "NS_PER_S",
    "nearest_step",
    "nearest_steps",
    "ns_from_parts",
    "ns_from_seconds",
    "ns_of",
    "seconds_from_ns",
    "set_ns",
    "split_ns",
    "steps_within",
]
