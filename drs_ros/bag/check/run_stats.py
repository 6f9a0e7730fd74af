"""What a recorded run did, in a few numbers, for a table of many bags: the peak piston force,
the largest flap gap, the longest interval between joint states, the refused and superseded
commands, the missed deadlines. Fed one decoded message at a time (nothing is kept), like
:class:`drs_ros.bag.check.model_checks.ModelChecker`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from drs_ros.bag.read.decoded import stamp_s
from drs_ros.bag.read.effects import effect_records
from drs_ros.names import DEFAULT_TOPICS, REFUSED, SUPERSEDED

#: The roles of the topics :class:`RunStats` reads (of :data:`drs_ros.names.NODE_TOPICS`).
STATS_ROLES = ("joint_states", "flap_gap", "command_events", "diagnostics")


@dataclass
class RunStats:
    """Running figures of a recorded run (NaN or 0 where the bag holds nothing to say it).

    Attributes
    ----------
    topics : Mapping
        Role -> topic of the node's topics (:data:`STATS_ROLES`; the default node's unless
        given: :func:`drs_ros.bag.read.nodes.resolve_topics`).
    diagnostics_name : str or None
        The node's status name in ``/diagnostics`` (another node's statuses there are not its);
        None: every status.
    joint_names : tuple or None
        The node's joint names (another node's joint states on a shared topic are not its);
        None: every joint state.
    peak_force_n : float
        Largest ``|effort|`` of the piston in the joint states [N].
    peak_force_at_s : float
        Its header stamp [s].
    largest_gap_m : float
        Largest ``~/flap_gap`` [m].
    longest_interval_s : float
        Longest time between consecutive joint state stamps [s] (a dropout).
    refused, superseded : int
        Commands the effect record (``~/command_events``) says were refused, superseded.
    missed_deadlines : int
        The node's ``missed_deadlines`` counter in its last ``/diagnostics`` (its largest value).
    """

    peak_force_n: float = math.nan
    peak_force_at_s: float = math.nan
    largest_gap_m: float = math.nan
    longest_interval_s: float = math.nan
    refused: int = 0
    superseded: int = 0
    missed_deadlines: int = 0
    topics: Mapping[str, str] = field(default_factory=lambda: dict(DEFAULT_TOPICS))
    diagnostics_name: str | None = None
    joint_names: tuple[str, ...] | None = None
    _last_stamp: float | None = None

    @property
    def read(self) -> list[str]:
        """The topics it reads."""
        return [self.topics[role] for role in STATS_ROLES]

    def add(self, topic: str, log_ns: int, msg) -> None:
        """One decoded message (topics other than :attr:`read` are ignored)."""
        tp = self.topics
        if topic == tp["joint_states"]:
            if self.joint_names is not None and tuple(msg.name) != self.joint_names:
                return  # another node's
            t = stamp_s(log_ns, msg)
            if self._last_stamp is not None:
                step = t - self._last_stamp
                if math.isnan(self.longest_interval_s) or step > self.longest_interval_s:
                    self.longest_interval_s = step
            self._last_stamp = t
            if len(msg.effort):
                force = abs(float(msg.effort[0]))
                if math.isfinite(force) and not force <= self.peak_force_n:
                    self.peak_force_n, self.peak_force_at_s = force, t
        elif topic == tp["flap_gap"]:
            gap = float(msg.data)
            if math.isfinite(gap) and not gap <= self.largest_gap_m:
                self.largest_gap_m = gap
        elif topic == tp["command_events"]:
            for record in effect_records([(log_ns, msg)]):
                self.refused += record.outcome == REFUSED
                self.superseded += record.outcome == SUPERSEDED
        elif topic == tp["diagnostics"]:
            for status in msg.status:
                if self.diagnostics_name is not None and status.name != self.diagnostics_name:
                    continue  # another node's
                for kv in status.values:
                    if kv.key == "missed_deadlines" and kv.value.isdigit():
                        self.missed_deadlines = max(self.missed_deadlines, int(kv.value))

    def row(self) -> dict[str, float | int]:
        """The figures as table columns."""
        return {
            "peak_force_n": self.peak_force_n,
            "peak_force_at_s": self.peak_force_at_s,
            "largest_gap_m": self.largest_gap_m,
            "longest_interval_s": self.longest_interval_s,
            "refused_commands": self.refused,
            "superseded_commands": self.superseded,
            "missed_deadlines": self.missed_deadlines,
        }


__all__ = ["STATS_ROLES", "RunStats"]
