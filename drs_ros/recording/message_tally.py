"""What a recorder has written: the messages per topic and in all, each channel's last sequence
number, the payload bytes, the earliest and latest log times (:class:`MessageTally`, which
``metadata.yaml`` and the summary are made from), and the snapshot of the counters a recorder
gives for diagnostics (:class:`RecorderStats`).
"""

from __future__ import annotations

from dataclasses import dataclass


class MessageTally:
    """The counts of a recording (not thread-safe: its recorder holds its lock around it).

    Attributes
    ----------
    counts : dict
        Messages written per topic.
    sequence : dict
        The last sequence number written per topic (0: none yet).
    message_count : int
        Messages written in all.
    bytes : int
        Serialised payload written [bytes].
    t_min, t_max : int or None
        The earliest and latest log times [ns] (None: no message yet).
    """

    def __init__(self) -> None:
        self.counts: dict[str, int] = {}
        self.sequence: dict[str, int] = {}
        self.message_count = 0
        self.bytes = 0
        self.t_min: int | None = None
        self.t_max: int | None = None

    def add_topic(self, topic: str) -> None:
        """A new topic, no message of it yet."""
        self.counts[topic] = 0
        self.sequence[topic] = 0

    def count(self, topic: str, size: int, log_ns: int, sequence: int | None = None) -> int:
        """One message more of ``topic``, ``size`` bytes logged at ``log_ns`` [ns]; returns its
        sequence number (the one given, or one more than the channel's last)."""
        seq = self.sequence[topic] + 1 if sequence is None else int(sequence)
        self.sequence[topic] = seq
        self.counts[topic] += 1
        self.message_count += 1
        self.bytes += size
        self.t_min = log_ns if self.t_min is None else min(self.t_min, log_ns)
        self.t_max = log_ns if self.t_max is None else max(self.t_max, log_ns)
        return seq


@dataclass(frozen=True)
class RecorderStats:
    """Counters for diagnostics (a snapshot).

    Attributes
    ----------
    messages : dict
        Messages written per topic.
    message_count : int
        Total messages written.
    bytes_written : int
        Total serialised payload [bytes].
    file_bytes : int
        Bytes handed to the OS so far (file size up to the last flush) [bytes].
    flush_count : int
        Chunk flushes so far.
    messages_flushed : int
        Messages safely in the file at the last flush (what a SIGKILL would keep).
    seconds_since_flush : float
        Age of the last flush (or of the start) [s].
    finished : bool
        Whether :meth:`McapRecorder.finish` ran.
    """

    messages: dict[str, int]
    message_count: int
    bytes_written: int
    file_bytes: int
    flush_count: int
    messages_flushed: int
    seconds_since_flush: float
    finished: bool
