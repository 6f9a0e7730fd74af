"""The errors of the recorders: the bag recorder and the QoS profile text it writes
(:class:`RecordingError`), the rerun recorder (:class:`RerunLogError`)."""

from __future__ import annotations

from ..errors import DRSRosError


class RecordingError(DRSRosError):
    """The recorder cannot do what was asked (unknown topic, wrong type, finished, bad path...)."""


class RerunLogError(DRSRosError):
    """The rerun recorder cannot do what was asked (it is closed, or an argument is invalid)."""


__all__ = ["RecordingError", "RerunLogError"]
