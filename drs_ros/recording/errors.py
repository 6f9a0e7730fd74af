"""The error of the recorders and of the QoS profile text they write (one class for both)."""

from __future__ import annotations

from drs_model.errors import DRSError


class RecordingError(DRSError):
    """The recorder cannot do what was asked (unknown topic, wrong type, finished, bad path...)."""


__all__ = ["RecordingError"]
