"""The messages of a verified bag, decoded: what ``drs-bag check``, ``drs-bag resimulate`` and
the tests read.

:func:`stream_bag` verifies the whole bag (:func:`drs_ros.bag.read.reader.scan`: every byte, every
file, a chunk at a time) and hands each message of the topics asked for, decoded with the
installed type support (:func:`decoder`), to a callback that keeps what it needs: memory does not
grow with the bag.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from drs_ros.bag.read.reader import scan
from drs_ros.bag.read.recorded import BagScan, RecordedMessage
from drs_ros.timestamps import ns_of, seconds_from_ns


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
    first_stamp_s : dict
        topic -> stamp [s] of its first message (header stamp, else log time), for each topic
        asked for that has one.
    start_ns, end_ns : int or None
        Earliest and latest log time of the messages read (every topic) [ns].
    """

    path: Path
    messages: dict[str, list] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    recovered: bool = False
    notes: list[str] = field(default_factory=list)
    first_stamp_s: dict[str, float] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int | None = None


def stamp_s(log_ns: int, msg) -> float:
    """A message's header stamp [s], or its log time for a message without one."""
    header = getattr(msg, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is not None and (stamp.sec or stamp.nanosec):
        return seconds_from_ns(ns_of(stamp))
    return seconds_from_ns(log_ns)


def decoder() -> Callable[[RecordedMessage], object]:
    """A function that decodes a recorded message with the installed type support (the message
    class of each type looked up once). It raises for a type that is not installed."""
    from rclpy.serialization import deserialize_message

    from drs_ros.recording import msgdefs

    classes: dict[str, type] = {}

    def decode(m: RecordedMessage) -> object:
        cls = classes.get(m.type_name) or classes.setdefault(
            m.type_name, msgdefs.message_class(m.type_name)
        )
        return deserialize_message(m.data, cls)

    return decode


def verified_what(result: BagScan) -> str:
    """What :func:`~drs_ros.bag.read.reader.scan` verified of a complete bag: the storage's own
    checks, ``metadata.yaml`` only when the bag has one, the exact CDR."""
    meta = result.metadata or {}
    sqlite = meta.get("storage_identifier") == "sqlite3" or result.path.suffix == ".db3"
    what = ["SQLite integrity check"] if sqlite else ["CRCs", "summary"]
    if result.metadata is not None:
        what.append("metadata.yaml")
    return ", ".join([*what, "exact CDR"])


def stream_bag(
    path: str | Path,
    topics: Sequence[str],
    on_decoded: Callable[[str, int, object], None],
    recover: bool = False,
) -> BagData:
    """Verify a whole bag (:func:`drs_ros.bag.read.reader.scan`) and call ``on_decoded(topic,
    log_time_ns, message)`` for each message of ``topics``, in file order, holding none of them
    (``messages`` of the result is empty).

    Raises
    ------
    BagReadError
        The bag is missing, unreadable, corrupt or inconsistent (with ``recover``: nothing of it
        is readable).
    MessageCallbackError
        Decoding a message that passed the file's checks failed (its type is not installed), or
        ``on_decoded`` raised: not a fault of the bag.
    """
    wanted = set(topics)
    decode = decoder()
    first: dict[str, float] = {}

    def take(m: RecordedMessage) -> None:
        msg = decode(m)
        if m.topic not in first:
            first[m.topic] = stamp_s(m.log_time, msg)
        on_decoded(m.topic, m.log_time, msg)

    result = scan(path, take, recover=recover, topics=wanted)
    notes = list(result.notes)
    if result.complete:
        notes.insert(
            0,
            f"verified: {result.message_count} messages, every byte read ({verified_what(result)})",
        )
    return BagData(
        result.path,
        {},
        dict(result.counts),
        not result.complete,
        notes,
        first,
        result.start_ns,
        result.end_ns,
    )


__all__ = ["BagData", "decoder", "stamp_s", "stream_bag", "verified_what"]
