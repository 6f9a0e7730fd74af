"""The QoS ``drs-bag play`` offers on each topic: what its recorders saw, adapted as rosbag2's
player adapts it, or what ``--qos-profile-overrides-path`` says.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from .options import PlayError

#: History depth of rosbag2's offers (``rmw_qos_profile_default.depth``).
DEFAULT_QOS_DEPTH = 10
#: ``RMW_DURATION_INFINITE`` [ns] and the Foxy-era spellings rosbag2 reads as infinite.
INFINITE_NS = 2**63 - 1
_FOXY_INFINITE = {(0x7FFFFFFF, 0xFFFFFFFF), (0x7FFFFFFF, 0x7FFFFFFF), divmod(INFINITE_NS, 10**9)}


def _duration_ns(value: Any) -> int:
    """A recorded ``{sec, nsec}`` duration [ns]; rosbag2's infinite spellings -> infinite."""
    sec, nsec = int(value["sec"]), int(value["nsec"])
    if (sec, nsec) in _FOXY_INFINITE:
        return INFINITE_NS
    return min(sec * 10**9 + nsec, INFINITE_NS)


def _policy(enum_type, value: Any):
    """A policy from its metadata-version-9 name (``reliable``) or a version <= 8 integer."""
    if isinstance(value, bool):
        raise ValueError(f"invalid QoS policy {value!r}")
    if isinstance(value, int):
        return enum_type(value)
    return enum_type[str(value).strip().upper()]


def qos_profile(offer: dict[str, Any]):
    """An rclpy ``QoSProfile`` from one recorded offer (a dict of ``offered_qos_profiles``)."""
    from rclpy.duration import Duration
    from rclpy.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        LivelinessPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )

    history = _policy(HistoryPolicy, offer.get("history", "keep_last"))
    return QoSProfile(
        history=history,
        depth=int(offer.get("depth", DEFAULT_QOS_DEPTH)),
        reliability=_policy(ReliabilityPolicy, offer["reliability"]),
        durability=_policy(DurabilityPolicy, offer["durability"]),
        deadline=Duration(nanoseconds=_duration_ns(offer["deadline"])),
        lifespan=Duration(nanoseconds=_duration_ns(offer["lifespan"])),
        liveliness=_policy(LivelinessPolicy, offer["liveliness"]),
        liveliness_lease_duration=Duration(
            nanoseconds=_duration_ns(offer["liveliness_lease_duration"])
        ),
        avoid_ros_namespace_conventions=bool(offer.get("avoid_ros_namespace_conventions", False)),
    )


#: The keys of a profile in ``offered_qos_profiles`` and in a QoS overrides file.
QOS_KEYS = frozenset(
    {
        "history",
        "depth",
        "reliability",
        "durability",
        "deadline",
        "lifespan",
        "liveliness",
        "liveliness_lease_duration",
        "avoid_ros_namespace_conventions",
    }
)


def qos_overrides(path: str | Path) -> dict[str, Any]:
    """Topic -> QoSProfile from a ``--qos-profile-overrides-path`` YAML file.

    Each value is a partial profile (missing policies keep rclpy's defaults: keep last 10,
    reliable, volatile). Raises :class:`PlayError` on an unreadable file or an unknown key.
    """
    try:
        text = Path(path).read_text()
        table = yaml.safe_load(text) or {}
        if not isinstance(table, dict):
            raise TypeError("expected a mapping of topic names to profiles")
        out = {}
        for topic, given in table.items():
            unknown = set(given) - QOS_KEYS
            if unknown:
                raise KeyError(
                    f"{topic}: unknown QoS keys {sorted(unknown)}, valid: {sorted(QOS_KEYS)}"
                )
            base = {
                "history": "keep_last",
                "depth": DEFAULT_QOS_DEPTH,
                "reliability": "reliable",
                "durability": "volatile",
                "liveliness": "system_default",
            }
            zero = {"sec": 0, "nsec": 0}  # unspecified: the middleware's default
            for key in ("deadline", "lifespan", "liveliness_lease_duration"):
                base[key] = zero
            out[str(topic)] = qos_profile({**base, **given})
        return out
    except (OSError, yaml.YAMLError, TypeError, KeyError, ValueError, AttributeError) as exc:
        raise PlayError(
            f"--qos-profile-overrides-path {str(path)!r}: {type(exc).__name__}: {exc}"
        ) from exc


def default_qos():
    """rosbag2's default offer (``Rosbag2QoS{}``): keep last 10, reliable, volatile."""
    from rclpy.qos import QoSProfile

    return QoSProfile(depth=DEFAULT_QOS_DEPTH)


def playback_qos(offered_yaml: str | None, topic: str) -> tuple[Any, str | None]:
    """The QoS to offer when playing ``topic``, as rosbag2 adapts its recorded offers.

    Parameters
    ----------
    offered_yaml : str or None
        The channel metadata ``offered_qos_profiles`` (a YAML list), or None / empty.
    topic : str
        Topic name (for the warning).

    Returns
    -------
    (QoSProfile, str or None)
        The profile and a warning (mixed or unreadable offers), or None.
    """
    if not offered_yaml or not offered_yaml.strip():
        return default_qos(), None
    try:
        offers = yaml.safe_load(offered_yaml) or []
        profiles = [qos_profile(offer) for offer in offers]
    except (yaml.YAMLError, KeyError, ValueError, TypeError, AttributeError) as exc:
        return default_qos(), (
            f"topic {topic}: unreadable offered_qos_profiles ({type(exc).__name__}: {exc}); "
            "using the default QoS (keep last 10, reliable, volatile)"
        )
    if not profiles:
        return default_qos(), None

    def compat(p):
        return (
            p.reliability,
            p.durability,
            p.deadline.nanoseconds,
            p.liveliness,
            p.liveliness_lease_duration.nanoseconds,
        )

    if any(compat(p) != compat(profiles[0]) for p in profiles[1:]):
        return default_qos(), (
            f"topic {topic}: its recorded publishers offered different QoS profiles; "
            "using the default QoS (keep last 10, reliable, volatile), as rosbag2 does"
        )
    from rclpy.qos import HistoryPolicy

    chosen = profiles[0]
    chosen.history = HistoryPolicy.KEEP_LAST
    chosen.depth = DEFAULT_QOS_DEPTH
    return chosen, None
