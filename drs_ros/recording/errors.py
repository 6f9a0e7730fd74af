"""The error of the recorders and of the QoS profile text they write (one class for both)."""

from __future__ import annotations

from ..errors import DRSRosError


class RecordingError(DRSRosError):
    """The recorder cannot do what was asked (unknown topic, wrong type, finished, bad path...)."""


__all__ = ["RecordingError"]
