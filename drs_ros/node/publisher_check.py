"""Publishers that cannot reach the node's command subscriptions: an incompatible QoS (a
best-effort publisher to the node's reliable subscription, ...) or another message type on the
topic.

rclpy's subscriptions warn of both through QoS-event waitables, which the node's do not carry
(:mod:`drs_ros.publishing`: they made every wake-up of the executor ~30 % dearer). The node asks
DDS instead, with its diagnostics (1 Hz, ~50 us a topic): each such publisher is logged once
(once more when the name of its node, which the graph can learn later, arrives) and reported in
diagnostics (``incompatible_publisher``) for as long as it stays.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from rclpy.qos import QoSCompatibility, qos_check_compatible

from ..recording.msgdefs import type_name

#: The kind of trouble diagnostics report for such a publisher.
INCOMPATIBLE_PUBLISHER = "incompatible_publisher"


class PublisherCheck:
    """Finds the publishers that cannot reach a subscription of ``node`` (asked with
    ``node.get_publishers_info_by_topic``); ``warn(text)`` logs each new one, once."""

    def __init__(self, node, warn: Callable[[str], None]) -> None:
        self._node, self._warn = node, warn
        self._warned: set[tuple[str, tuple[int, ...], str]] = set()

    def problems(self, subscriptions: Iterable) -> list[str]:
        """One reason per publisher that cannot reach one of ``subscriptions`` (rclpy
        subscriptions; None is skipped), naming the publisher's node, the topic and why."""
        out = []
        for sub in subscriptions:
            if sub is None:
                continue
            expected = type_name(sub.msg_type)
            for info in self._node.get_publishers_info_by_topic(sub.topic_name):
                why = _why_unreachable(info, expected, sub.qos_profile)
                if why is None:
                    continue
                who = _publisher_node(info)
                text = f"{who} publishes on {sub.topic_name}, which the node cannot take: {why}"
                # once more when its node's name arrives (the graph can lag the endpoint)
                key = (sub.topic_name, tuple(info.endpoint_gid), who)
                if key not in self._warned:
                    self._warned.add(key)
                    self._warn(text)
                out.append(text)
        return out


def _publisher_node(info) -> str:
    """The publishing node's full name, or what is known of it."""
    if "_UNKNOWN_" in info.node_name:  # rmw's placeholder before the node is discovered
        return "a publisher (its node not yet discovered)"
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"


def _why_unreachable(info, expected_type: str, subscription_qos) -> str | None:
    """Why the publisher ``info`` (a ``TopicEndpointInfo``) cannot reach a subscription of
    ``expected_type`` with ``subscription_qos``, or None when it can (or it cannot be told)."""
    if info.topic_type != expected_type:
        return f"its type is {info.topic_type}, the node's {expected_type}"
    compatibility, reason = qos_check_compatible(info.qos_profile, subscription_qos)
    if compatibility == QoSCompatibility.ERROR:
        return f"incompatible QoS: {reason}"
    return None


__all__ = ["INCOMPATIBLE_PUBLISHER", "PublisherCheck"]
