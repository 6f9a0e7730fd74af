"""Messages serialised whole, for tests: the references tests compare the node's packed bytes
with. Importing this module imports rclpy's message classes."""

from __future__ import annotations

from drs_ros.recording import cdr


def serialize(msg) -> bytes:
    """The exact CDR bytes of one rclpy message (drs_ros.recording.cdr.serializer)."""
    return cdr.serializer(type(msg))(msg)
