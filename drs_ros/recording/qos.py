"""QoS profiles as rosbag2 writes them into a bag: the ``offered_qos_profiles`` channel metadata.

rosbag2 (metadata version 9) stores each publisher's offered profile as a YAML map of policy
names (``reliable``, ``transient_local``...) and ``{sec, nsec}`` durations; a channel holds a YAML
list of them. :func:`qos_dict` makes such a map of an rclpy ``QoSProfile``, :func:`qos_yaml` the
channel's text of a list of maps; :func:`parse_qos_yaml` reads the list back from the text, and
:func:`qos_profile` makes an rclpy ``QoSProfile`` of one map again (also of the integer policies
and Foxy-era infinite durations of older bags, as rosbag2 reads them).
"""

from __future__ import annotations

from typing import Any

import yaml

from ..timestamps import ns_from_parts, split_ns
from .errors import RecordingError

#: ``RMW_DURATION_INFINITE`` [ns].
INFINITE_NS = 2**63 - 1
#: ``RMW_DURATION_INFINITE`` as rosbag2 serialises it.
INFINITE_DURATION = dict(zip(("sec", "nsec"), split_ns(INFINITE_NS), strict=True))
#: The Foxy-era spellings of an infinite duration that rosbag2 reads as infinite.
_FOXY_INFINITE = {(0x7FFFFFFF, 0xFFFFFFFF), (0x7FFFFFFF, 0x7FFFFFFF), split_ns(INFINITE_NS)}
#: History depth of ``rmw_qos_profile_default`` (rosbag2's own offers, ``QoSProfile(depth=10)``).
DEFAULT_DEPTH = 10
#: The keys of a profile in ``offered_qos_profiles`` (and in ``drs-bag play``'s overrides file).
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


def _policy_name(value: Any, resolved: str) -> str:
    """Lower-case policy name; ``system_default`` resolved to what Fast DDS offers."""
    name = getattr(value, "name", str(value)).lower()
    return resolved if name == "system_default" else name


def _duration(value: Any) -> dict[str, int]:
    ns = int(getattr(value, "nanoseconds", value))
    if ns <= 0 or ns >= INFINITE_NS:  # unspecified (0) is infinite on the wire
        return dict(INFINITE_DURATION)
    return dict(zip(("sec", "nsec"), split_ns(ns), strict=True))


def qos_dict(qos: Any = None) -> dict[str, Any]:
    """A QoS profile as rosbag2 (metadata version 9) serialises an offered profile.

    Parameters
    ----------
    qos : rclpy.qos.QoSProfile or int or None
        The publisher's profile; an int is a KEEP_LAST depth; None means ``QoSProfile(depth=10)``.

    Returns
    -------
    dict
        ``history``, ``depth``, ``reliability``, ``durability``, ``deadline``, ``lifespan``,
        ``liveliness``, ``liveliness_lease_duration``, ``avoid_ros_namespace_conventions``.
        ``system_default`` policies and unspecified durations are resolved as the Fast DDS graph
        reports them to ``ros2 bag record`` (reliable, volatile, automatic, infinite).
    """
    if qos is None or isinstance(qos, int):
        from rclpy.qos import QoSProfile

        depth = DEFAULT_DEPTH if qos is None else qos
        if isinstance(depth, bool) or depth < 0:
            raise RecordingError(f"QoS depth must be an int >= 0, got {qos!r}")
        qos = QoSProfile(depth=depth)
    try:
        return {
            "history": _policy_name(qos.history, "keep_last"),
            "depth": int(qos.depth),
            "reliability": _policy_name(qos.reliability, "reliable"),
            "durability": _policy_name(qos.durability, "volatile"),
            "deadline": _duration(qos.deadline),
            "lifespan": _duration(qos.lifespan),
            "liveliness": _policy_name(qos.liveliness, "automatic"),
            "liveliness_lease_duration": _duration(qos.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": bool(qos.avoid_ros_namespace_conventions),
        }
    except AttributeError as exc:
        raise RecordingError(f"expected an rclpy QoSProfile, a depth or None, got {qos!r}") from exc


def qos_yaml(profiles: list[dict[str, Any]]) -> str:
    """The ``offered_qos_profiles`` channel metadata (yaml-cpp block style, no final newline)."""
    lines = []
    for prof in profiles:
        first = True
        for key, value in prof.items():
            lead = "- " if first else "  "
            first = False
            if isinstance(value, dict):
                lines.append(f"{lead}{key}:")
                lines += [f"    {k}: {v}" for k, v in value.items()]
            elif isinstance(value, bool):
                lines.append(f"{lead}{key}: {'true' if value else 'false'}")
            else:
                lines.append(f"{lead}{key}: {value}")
    return "\n".join(lines)


def parse_qos_yaml(text: str) -> list[dict[str, Any]]:
    """The profiles of an ``offered_qos_profiles`` string (the inverse of :func:`qos_yaml`)."""
    if not text:
        return []
    try:
        profiles = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise RecordingError(f"offered_qos_profiles is not YAML: {exc}") from exc
    if not isinstance(profiles, list) or not all(isinstance(p, dict) for p in profiles):
        raise RecordingError(f"offered_qos_profiles must be a list of maps, got {text[:80]!r}")
    return profiles


def _duration_ns(value: Any) -> int:
    """A recorded ``{sec, nsec}`` duration [ns]; rosbag2's infinite spellings -> infinite."""
    sec, nsec = int(value["sec"]), int(value["nsec"])
    if (sec, nsec) in _FOXY_INFINITE:
        return INFINITE_NS
    return min(ns_from_parts(sec, nsec), INFINITE_NS)


def _policy_value(enum_type, value: Any):
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

    history = _policy_value(HistoryPolicy, offer.get("history", "keep_last"))
    return QoSProfile(
        history=history,
        depth=int(offer.get("depth", DEFAULT_DEPTH)),
        reliability=_policy_value(ReliabilityPolicy, offer["reliability"]),
        durability=_policy_value(DurabilityPolicy, offer["durability"]),
        deadline=Duration(nanoseconds=_duration_ns(offer["deadline"])),
        lifespan=Duration(nanoseconds=_duration_ns(offer["lifespan"])),
        liveliness=_policy_value(LivelinessPolicy, offer["liveliness"]),
        liveliness_lease_duration=Duration(
            nanoseconds=_duration_ns(offer["liveliness_lease_duration"])
        ),
        avoid_ros_namespace_conventions=bool(offer.get("avoid_ros_namespace_conventions", False)),
    )


__all__ = [
    "DEFAULT_DEPTH",
    "INFINITE_DURATION",
    "INFINITE_NS",
    "QOS_KEYS",
    "parse_qos_yaml",
    "qos_dict",
    "qos_profile",
    "qos_yaml",
]
