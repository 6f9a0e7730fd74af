"""The QoS ``drs-bag play`` offers on each topic: what its recorders saw, adapted as rosbag2's
player adapts it, or what ``--qos-profile-overrides-path`` says.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from drs_model.overrides import parse_error_text
from drs_ros.bag.replay.play.options import PlayError
from drs_ros.recording.errors import RecordingError
from drs_ros.recording.qos import DEFAULT_DEPTH, QOS_KEYS, parse_qos_yaml, qos_profile


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
                "depth": DEFAULT_DEPTH,
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
            f"--qos-profile-overrides-path {str(path)!r}: {type(exc).__name__}: "
            f"{parse_error_text(exc)}"
        ) from exc


def default_qos():
    """rosbag2's default offer (``Rosbag2QoS{}``): keep last 10, reliable, volatile."""
    from rclpy.qos import QoSProfile

    return QoSProfile(depth=DEFAULT_DEPTH)


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
        profiles = [qos_profile(offer) for offer in parse_qos_yaml(offered_yaml)]
    except (RecordingError, KeyError, ValueError, TypeError, AttributeError) as exc:
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
    chosen.depth = DEFAULT_DEPTH
    return chosen, None
