"""Read a rosbag2 MCAP bag and verify every byte of it (what ``drs-bag check`` trusts).

:func:`scan` reads the file sequentially, record by record, and stops at the first problem with a
:class:`BagReadError` naming the offset, the record and, where there is one, the topic:

* the magic bytes at both ends, and nothing after the closing magic;
* every chunk's CRC (the uncompressed data) and the data section CRC, as written;
* the summary: its CRC (footer ``summary_crc``, computed here: the mcap reader does not), every
  chunk index pointing at a chunk that was read at that offset, and the statistics' message
  counts per channel against the messages actually read;
* every message: its channel is known, and its bytes are exactly its CDR serialisation: it is
  decoded by the installed type support (``rclpy.serialization.deserialize_message``) and
  serialised again by :mod:`drs_ros.recording.cdr`; bytes that differ from it are an error,
  but for up to 3 trailing zero bytes (the transport's) and non-zero alignment padding (its
  content is unspecified; noted per topic);
* a bag directory's ``metadata.yaml``: present, well formed
  (:func:`drs_ros.bag.read.files.read_metadata`), naming files that exist, and its per-topic counts
  equal to what was read from all of them.

A bag split into several files (``name_0.mcap``, ``name_1.mcap``... as rosbag2 splits) is read
file by file, in order (:func:`drs_ros.bag.read.files.resolve` is the one place that finds a bag's
files).

A sqlite3 bag (rosbag2's ``.db3`` storage, :mod:`drs_ros.bag.read.sqlite`) is read row by row in
the order rosbag2 wrote it, after SQLite's integrity check of every page, with the same message
checks and the same ``metadata.yaml`` counts.

With ``recover=True`` the scan keeps what it read before a truncation or a corrupt record and
reports where and why it stopped, instead of raising; in a split bag each file is read up to its
own first problem.

Only the file decides a :class:`BagReadError`. An exception raised by the caller's ``on_message``
callback says nothing about the file: it is raised as :class:`MessageCallbackError` (its cause is
the callback's exception), with or without ``recover``, and never ends a scan as a truncation.

No state beyond the scan's own result; rclpy is used only for its type support.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

from drs_ros.bag.read.files import BagFiles, BagReadError, resolve
from drs_ros.bag.read.mcap_file import scan_file
from drs_ros.bag.read.recorded import BagScan, ChannelInfo, MessageCallbackError, RecordedMessage


def _exact_checker(
    padded: dict[str, int], filled: dict[str, int]
) -> Callable[[str, str, bytes], str | None]:
    """``check(topic, type_name, data) -> problem, '' (exact) or None (type not installed)``:
    decode with the installed type support and serialise again exactly. Up to 3 zero bytes after the
    exact CDR are the DDS transport's padding (:func:`drs_ros.recording.cdr_received.exact_bytes`):
    rosbag2 records them as they arrive; they are counted in ``padded`` per type, not refused.
    Non-zero alignment padding (its content is unspecified, rclpy decodes the message) is counted in
    ``filled`` per topic, not refused: the bytes with their padding zeroed
    (:func:`~drs_ros.recording.cdr_padding.zero_padding`) must be the exact CDR; any other
    difference is a problem."""
    from rclpy.serialization import deserialize_message

    from drs_model.cli.start_signals import signal_received
    from drs_ros.recording import cdr, cdr_received, msgdefs
    from drs_ros.recording.cdr_padding import zero_padding

    classes: dict[str, Any] = {}

    def check(topic: str, type_name: str, data: bytes) -> str | None:
        cls = classes.get(type_name)
        if cls is None:
            try:
                cls = msgdefs.message_class(type_name)
            except msgdefs.MessageDefinitionError:
                cls = False
            classes[type_name] = cls
        if cls is False:
            return None  # not installed: counted, not verified (noted by the caller)
        try:
            again = cdr.serializer(cls)(deserialize_message(data, cls))
        except Exception as exc:  # noqa: BLE001 - any decode failure is the bag's problem
            if signal_received():  # a SIGINT pybind11 turned into a TypeError: no verdict
                raise KeyboardInterrupt from exc
            return f"does not decode as {type_name} ({type(exc).__name__}: {exc})"
        if again == data:
            return ""
        tail = data[len(again) :]
        if data.startswith(again) and cdr_received.is_transport_padding(tail):
            padded[type_name] = padded.get(type_name, 0) + 1  # DDS's padding, not a leak
            return ""
        try:
            if zero_padding(data, cls) == again:  # a difference in alignment padding only
                filled[topic] = filled.get(topic, 0) + 1
                return ""
        except cdr.CdrError:
            pass  # not even CDR of its type in the walk: the difference below says where
        if len(data) != len(again):
            return (
                f"is {len(data)} bytes where its CDR serialisation is {len(again)} "
                f"({len(data) - len(again):+d} bytes)"
            )
        first = next(i for i, (a, b) in enumerate(zip(data, again, strict=True)) if a != b)
        return f"differs from its CDR serialisation at byte {first}, which is not alignment padding"

    return check


def scan(
    path: str | Path,
    on_message: Callable[[RecordedMessage], None] | None = None,
    *,
    recover: bool = False,
    exact: bool = True,
    topics: Iterable[str] | None = None,
) -> BagScan:
    """Read and verify a bag (see the module docstring); call ``on_message`` for each message.

    Parameters
    ----------
    path : str or Path
        Bag directory or ``.mcap`` file.
    on_message : callable, optional
        Called with each :class:`RecordedMessage` of ``topics`` (all topics by default), in file
        order, file after file, once the message passed its checks.
    recover : bool
        Keep what was read before a truncation or corruption instead of raising (a directory
        without ``metadata.yaml`` is then accepted too). In a split bag every file is read up to
        its own first problem; a file with nothing readable is reported in ``reason``.
    exact : bool
        Verify that every message's bytes are its exact CDR serialisation.
    topics : iterable of str, optional
        Topics passed to ``on_message``; every message is verified regardless.

    Raises
    ------
    BagReadError
        Without ``recover``: any problem of the bag; with it: nothing readable at all.
    BagMetadataError
        ``metadata.yaml`` is malformed (a :class:`BagReadError`).
    MessageCallbackError
        ``on_message`` raised (with or without ``recover``): the scan ends there, and nothing is
        said about the rest of the bag.
    """
    bag = resolve(path, require_metadata=not recover)
    wanted = None if topics is None else set(topics)
    padded: dict[str, int] = {}
    filled: dict[str, int] = {}
    check = _exact_checker(padded, filled) if exact else None
    unverified: set[str] = set()
    take = partial(_take, check=check, unverified=unverified, on_message=on_message, wanted=wanted)
    parts: list[BagScan] = []
    if bag.storage == "sqlite3":  # one result for the bag (its files are one database to rosbags)
        parts.append(_scan_sqlite(bag, on_message, check, wanted, unverified))
    for file in bag.files if bag.storage == "mcap" else ():
        try:
            part = scan_file(file, bag.bag_dir, take, recover)
        except BagReadError as exc:
            if not recover or len(bag.files) == 1:
                raise
            reason = str(exc).split(": ", 1)[-1]
            part = BagScan(
                file,
                bag.bag_dir,
                stopped_at=0,
                file_size=file.stat().st_size,
                reason=reason,
                notes=[f"nothing readable: {reason}"],
            )
        parts.append(part)
    out = parts[0] if len(parts) == 1 else _combine(bag, parts)
    if recover and out.message_count == 0 and not out.complete:
        raise BagReadError(f"{str(out.path)!r}: nothing recoverable in any file: {out.reason}")
    _conclude(out, bag, unverified, filled, padded)
    return out


def _conclude(
    out: BagScan,
    bag: BagFiles,
    unverified: set[str],
    filled: dict[str, int],
    padded: dict[str, int],
) -> None:
    """What a whole scan adds to its result: the bag's ``metadata.yaml`` (checked against what
    was read when the scan completed) and the notes of what it could not verify or found
    padded."""
    out.metadata = bag.metadata
    if bag.metadata is not None and out.complete:
        _check_metadata(out, bag.metadata, bag.bag_dir / "metadata.yaml")
    if out.complete and unverified:
        out.notes.append(f"types not installed, bytes not verified: {sorted(unverified)}")
    if filled:  # said of a recovered part too: what was read of it holds them
        out.notes.append(
            f"messages whose CDR alignment padding holds non-zero bytes (its "
            f"content is unspecified; rclpy decodes them, every other byte is "
            f"their exact CDR), per topic: {filled}"
        )
    if out.complete and padded:
        out.notes.append(
            f"messages carrying the DDS transport's zero padding (<= 3 bytes) after "
            f"their exact CDR: {padded}"
        )


def _combine(bag: BagFiles, parts: list[BagScan]) -> BagScan:
    """One result of a split bag's per-file scans (see :class:`BagScan`)."""
    out = BagScan(bag.bag_dir, bag.bag_dir, parts=parts)
    first: dict[str, tuple[ChannelInfo, Path]] = {}
    for part in parts:
        for channel in part.channels.values():
            known = first.get(channel.topic)
            if known is None:
                first[channel.topic] = (channel, part.path)
                out.channels[len(first)] = replace(channel, id=len(first))
            elif known[0].type_name != channel.type_name:
                raise BagReadError(
                    f"{str(bag.bag_dir)!r}: {channel.topic} is {known[0].type_name} in "
                    f"{known[1].name} and {channel.type_name} in {part.path.name}"
                )
        for topic, n in part.counts.items():
            out.counts[topic] = out.counts.get(topic, 0) + n
        for t in (part.start_ns, part.end_ns):
            if t is not None:
                out.start_ns = t if out.start_ns is None else min(out.start_ns, t)
                out.end_ns = t if out.end_ns is None else max(out.end_ns, t)
        out.file_size += part.file_size
        out.notes += [f"{part.path.name}: {note}" for note in part.notes]
    stopped = [part for part in parts if not part.complete]
    out.complete = not stopped
    if stopped:
        out.stopped_at, out.last_good_offset = stopped[0].stopped_at, stopped[0].last_good_offset
        out.reason = "; ".join(f"{part.path.name}: {part.reason}" for part in stopped)
    return out


def _take(
    out: BagScan,
    rec,
    at: int,
    path: Path,
    check: Callable[[str, str, bytes], str | None] | None,
    unverified: set[str],
    on_message: Callable[[RecordedMessage], None] | None,
    wanted: set[str] | None,
) -> None:
    """One message record (``channel_id``, ``log_time``, ``publish_time``, ``sequence``,
    ``data``) read at offset ``at`` of ``path``: its channel known, its bytes exact, counted, and
    handed to ``on_message`` (whose failure is a :class:`MessageCallbackError`)."""
    channel = out.channels.get(rec.channel_id)
    if channel is None:
        raise BagReadError(
            f"{str(path)!r}: a message at offset {at} names channel "
            f"{rec.channel_id}, never declared"
        )
    if check is not None:
        problem = check(channel.topic, channel.type_name, rec.data)
        if problem is None:
            unverified.add(channel.type_name)
        elif problem:
            raise BagReadError(
                f"{str(path)!r}: message {out.counts.get(channel.topic, 0) + 1} "
                f"of {channel.topic} (chunk at offset {at}) {problem}"
            )
    n = out.counts[channel.topic] = out.counts.get(channel.topic, 0) + 1
    out.start_ns = rec.log_time if out.start_ns is None else min(out.start_ns, rec.log_time)
    out.end_ns = rec.log_time if out.end_ns is None else max(out.end_ns, rec.log_time)
    if on_message is not None and (wanted is None or channel.topic in wanted):
        message = RecordedMessage.of_record(channel, rec, at)
        try:
            on_message(message)
        except Exception as exc:  # the caller's failure, not the file's: never a verdict
            said = " ".join(str(exc).split()) or "(no message)"
            raise MessageCallbackError(
                f"{str(path)!r}: message {n} of {channel.topic} (offset {at}) passed "
                f"every check of the file, then the caller's on_message callback raised "
                f"{type(exc).__name__}: {said}",
                path,
                channel.topic,
                n,
                at,
            ) from exc


def _scan_sqlite(
    bag: BagFiles,
    on_message: Callable[[RecordedMessage], None] | None,
    check: Callable[[str, str, bytes], str | None] | None,
    wanted: set[str] | None,
    unverified: set[str],
) -> BagScan:
    """Read and verify a sqlite3 bag (:mod:`drs_ros.bag.read.sqlite`): every page of each database
    (SQLite's integrity check), then every message, in time order, as
    :func:`.mcap_file.scan_file` does (its row number in the file is its ``offset``)."""
    from drs_ros.bag.read import sqlite

    path = bag.bag_dir if bag.bag_dir is not None else bag.files[0]
    out = BagScan(path, bag.bag_dir, file_size=sum(f.stat().st_size for f in bag.files))
    for file in bag.files:
        sqlite.check_integrity(file)
    for channel in sqlite.channels(bag):
        out.channels[channel["id"]] = ChannelInfo(**channel)
        out.counts.setdefault(channel["topic"], 0)
    for row, rec in enumerate(sqlite.iter_rows(bag), start=1):
        _take(out, rec, row, path, check, unverified, on_message, wanted)
    out.complete = True
    return out


def _check_metadata(out: BagScan, meta: dict, meta_path: Path) -> None:
    """``metadata.yaml``'s counts (checked by :func:`~drs_ros.bag.read.files.read_metadata`) against
    what was read."""
    where = str(meta_path)
    held = "the file holds" if not out.parts else f"its {len(out.parts)} files hold"
    listed: dict[str, int] = {}
    for t in meta["topics_with_message_count"]:
        name = t["topic_metadata"]["name"]
        listed[name] = listed.get(name, 0) + t["message_count"]
    for topic, n in listed.items():
        if out.counts.get(topic) is None:
            raise BagReadError(f"{where!r}: lists {topic} ({n} messages); {held} no such topic")
        if out.counts[topic] != n:
            raise BagReadError(
                f"{where!r}: counts {n} messages on {topic}, {held} {out.counts[topic]} "
                f"({n - out.counts[topic]:+d})"
            )
    extra = sorted(set(out.counts) - set(listed))
    if extra:
        raise BagReadError(f"{where!r}: does not list the topics {extra} of the bag")
    total = meta["message_count"]
    if total != out.message_count:
        raise BagReadError(f"{where!r}: counts {total} messages, {held} {out.message_count}")


__all__ = ["scan"]
