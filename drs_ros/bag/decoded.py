"""The messages of a verified bag, decoded: what ``drs-bag check``, ``drs-bag resimulate`` and
the tests read.

:func:`read_bag` verifies the whole bag (:func:`drs_ros.bag.reader.scan`: every byte, every
file) and decodes the messages of the topics asked for with the installed type support
(:func:`decoder`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .reader import RecordedMessage, scan


@dataclass
class BagData:
    """Decoded messages of the topics of interest.

    Attributes
    ----------
    path : Path
        The ``.mcap`` file read.
    messages : dict
        topic -> list of ``(log_time_ns, decoded message)`` in file order.
    counts : dict
        topic -> number of messages (every topic of the file), as read.
    recovered : bool
        The bag is damaged and only its readable part was read (``--recover``).
    notes : list of str
        What the reader had to say (verification, truncation point...).
    """

    path: Path
    messages: dict[str, list] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    recovered: bool = False
    notes: list[str] = field(default_factory=list)


def decoder() -> Callable[[RecordedMessage], object]:
    """A function that decodes a recorded message with the installed type support (the message
    class of each type looked up once). It raises for a type that is not installed."""
    from rclpy.serialization import deserialize_message

    from ..recording import msgdefs

    classes: dict[str, type] = {}

    def decode(m: RecordedMessage) -> object:
        cls = classes.get(m.type_name) or classes.setdefault(
            m.type_name, msgdefs.message_class(m.type_name)
        )
        return deserialize_message(m.data, cls)

    return decode


def read_bag(path: str | Path, topics: Sequence[str], recover: bool = False) -> BagData:
    """Verify a whole bag (:func:`drs_ros.bag.reader.scan`) and decode the messages of ``topics``.

    Raises
    ------
    BagReadError
        The bag is missing, unreadable, corrupt or inconsistent (with ``recover``: nothing of it
        is readable).
    MessageCallbackError
        Decoding a message that passed the file's checks failed (its type is not installed):
        not a fault of the bag.
    """
    wanted = set(topics)
    messages: dict[str, list] = {t: [] for t in topics}
    decode = decoder()

    def keep(m: RecordedMessage) -> None:
        messages[m.topic].append((m.log_time, decode(m)))

    result = scan(path, keep, recover=recover, topics=wanted)
    notes = list(result.notes)
    if result.complete:
        notes.insert(0, f"verified: {result.message_count} messages, every byte read "
                        "(CRCs, summary, metadata.yaml, exact CDR)")  # fmt: skip
    return BagData(result.path, messages, dict(result.counts), not result.complete, notes)


__all__ = ["BagData", "decoder", "read_bag"]
