"""QoS profiles as rosbag2 writes them into a bag: the ``offered_qos_profiles`` channel metadata.

rosbag2 (metadata version 9) stores each publisher's offered profile as a YAML map of policy
names (``reliable``, ``transient_local``...) and ``{sec, nsec}`` durations; a channel holds a YAML
list of them. :func:`qos_dict` makes such a map of an rclpy ``QoSProfile``, :func:`qos_yaml` the
channel's text of a list of maps, and :func:`parse_qos_yaml` the list back from the text.
"""

from __future__ import annotations

from typing import Any

import yaml

from .errors import RecordingError

#: ``RMW_DURATION_INFINITE`` as rosbag2 serialises it.
INFINITE_DURATION = {"sec": 9223372036, "nsec": 854775807}


def _policy(value: Any, resolved: str) -> str:
    """Lower-case policy name; ``system_default`` resolved to what Fast DDS offers."""
    name = getattr(value, "name", str(value)).lower()
    return resolved if name == "system_default" else name


def _duration(value: Any) -> dict[str, int]:
    ns = int(getattr(value, "nanoseconds", value))
    if ns <= 0 or ns >= 2**63 - 1:  # unspecified (0) is infinite on the wire
        return dict(INFINITE_DURATION)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


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

        depth = 10 if qos is None else qos
        if isinstance(depth, bool) or depth < 0:
            raise RecordingError(f"QoS depth must be an int >= 0, got {qos!r}")
        qos = QoSProfile(depth=depth)
    try:
        return {
            "history": _policy(qos.history, "keep_last"),
            "depth": int(qos.depth),
            "reliability": _policy(qos.reliability, "reliable"),
            "durability": _policy(qos.durability, "volatile"),
            "deadline": _duration(qos.deadline),
            "lifespan": _duration(qos.lifespan),
            "liveliness": _policy(qos.liveliness, "automatic"),
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


__all__ = ["INFINITE_DURATION", "parse_qos_yaml", "qos_dict", "qos_yaml"]
