"""A rosbag2-compatible MCAP recorder (``ros2`` profile, ``ros2msg`` schemas, ``cdr`` channels).

What rosbag2 (Jazzy, ``rosbag2_storage_mcap``) writes, and this module reproduces:

* header profile ``ros2``;
* one schema per message type: name ``pkg/msg/Type``, encoding ``ros2msg``, data the full
  definition text (:func:`drs_ros.recording.msgdefs.full_definition`);
* one channel per topic: message encoding ``cdr``, metadata ``offered_qos_profiles`` (a YAML
  string, the version-9 form with policy names) and ``topic_type_hash`` (``RIHS01_...``);
* messages as their exact CDR bytes: the bytes a raw subscription received, or a message
  serialised by :mod:`drs_ros.recording.cdr` (never ``rclpy.serialization.serialize_message``,
  whose buffer can carry trailing bytes and uninitialised padding); ``log_time`` (receive) and
  ``publish_time`` (send) in integer nanoseconds, and a per-channel sequence number;
* service calls as rosbag2 Jazzy records them: the introspection events of ``<service>`` on
  ``<service>/_service_event`` (``pkg/srv/Name_Event``; see :mod:`drs_ros.recording.msgdefs` for
  the schema text, and why such channels carry no ``topic_type_hash``);
* on finish, a metadata record ``rosbag2`` holding ``serialized_metadata`` (the bag metadata as
  YAML) and ``metadata.yaml`` (version 9, key ``rosbag2_bagfile_information``) beside the file.

A bag is a directory: ``McapRecorder("bags/demo")`` writes ``bags/demo/demo_0.mcap`` and, on
:meth:`McapRecorder.finish`, ``bags/demo/metadata.yaml``.

Crash safety: the MCAP writer buffers a chunk (1 MiB by default) in memory, so a process killed
with SIGKILL before its first chunk completes leaves a file holding only the header. The recorder
therefore closes the chunk in progress every ``flush_period`` seconds and every
``flush_messages`` messages (and when writes stop for a period), and a background thread
compresses it and hands it to the OS (:mod:`drs_ros.recording.chunk_flusher`): the thread that
writes messages never waits for the file. A SIGKILL then loses at most the last period;
``drs-bag recover`` turns the flushed prefix into a complete bag. A seeking
reader needs the summary, which only :meth:`finish` writes: the node finishes the recorder on
SIGINT/SIGTERM.

Failures: an I/O error of a write or a flush (a full disk; the file removed, which each flush
checks: an unlinked file would take every write and vanish at close) is kept in
:attr:`McapRecorder.io_error` and raised again by every later write, as an ``OSError``, so that
its owner sees it whichever thread met it first. :meth:`finish` names what it could not write
(the summary and footer, ``metadata.yaml``); :meth:`abandon` closes a failed file as it is.
"""

from __future__ import annotations

import operator
import os
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml
from mcap import __version__ as _mcap_version
from mcap.writer import CompressionType, Writer

from . import cdr, msgdefs
from .bag_metadata import TopicInfo, bag_metadata
from .chunk_flusher import ChunkFlusher
from .destinations import check_new_bag
from .errors import RecordingError
from .flush_schedule import FlushSchedule
from .mcap_append import MessageAppender
from .message_tally import MessageTally, RecorderStats
from .qos import qos_dict, qos_yaml

_COMPRESSION = {
    "none": CompressionType.NONE,
    "lz4": CompressionType.LZ4,
    "zstd": CompressionType.ZSTD,
}
_LIBRARY = f"drs_ros.recording (mcap-python {_mcap_version})"


class McapRecorder:
    """Record ROS 2 messages into a rosbag2-compatible MCAP bag directory.

    Parameters
    ----------
    bag_dir : str or Path
        Bag directory to create; the file is ``<bag_dir>/<name>_0.mcap``.
    overwrite : bool
        Replace an existing non-empty bag directory's files (otherwise :class:`RecordingError`).
    flush_period : float
        Maximum time between chunk flushes [s] (> 0; 0.5 by default).
    flush_messages : int or None
        Also flush after this many messages since the last flush (None: time only).
    chunk_size : int
        Chunk size bound [bytes] (a chunk is also closed at each flush).
    compression : {"none", "lz4", "zstd"}
        Chunk compression.
    flush_thread : bool
        Run a daemon thread that flushes when writes stop for longer than ``flush_period``.
    ros_distro : str
        Written into the metadata.
    custom_data : mapping of str to str, optional
        rosbag2's ``custom_data`` (e.g. the parameter set).

    Examples
    --------
    >>> with McapRecorder("bags/demo") as rec:                      # doctest: +SKIP
    ...     rec.register_topic("/joint_states", JointState, qos=10)
    ...     rec.write("/joint_states", msg, log_time_ns=t_ns)
    """

    def __init__(
        self,
        bag_dir: str | os.PathLike,
        *,
        overwrite: bool = False,
        flush_period: float = 0.5,
        flush_messages: int | None = None,
        chunk_size: int = 1024 * 1024,
        compression: str = "none",
        flush_thread: bool = True,
        ros_distro: str = "jazzy",
        custom_data: Mapping[str, str] | None = None,
    ) -> None:
        schedule = FlushSchedule(flush_period, flush_messages)
        if compression not in _COMPRESSION:
            raise RecordingError(
                f"compression must be one of {sorted(_COMPRESSION)}, got {compression!r}"
            )
        self.bag_dir = Path(bag_dir)
        if not self.bag_dir.name:
            raise RecordingError(f"bag_dir must name a directory, got {str(bag_dir)!r}")
        self.path = self.bag_dir / f"{self.bag_dir.name}_0.mcap"
        self.metadata_path = self.bag_dir / "metadata.yaml"
        if not overwrite:
            check_new_bag(self.bag_dir)
        elif self.bag_dir.exists() and not self.bag_dir.is_dir():
            raise RecordingError(f"bag directory {str(self.bag_dir)!r} exists and is a file")
        self.ros_distro = ros_distro
        self.custom_data = dict(custom_data or {})
        try:
            self.bag_dir.mkdir(parents=True, exist_ok=True)
            for stale in (self.path, self.metadata_path):
                stale.unlink(missing_ok=True)
            self._stream = open(self.path, "wb")  # noqa: SIM115 - closed in finish()
        except OSError as exc:
            raise RecordingError(f"cannot create bag {str(self.path)!r}: {exc}") from exc
        self._writer = Writer(
            self._stream,
            chunk_size=int(chunk_size),
            compression=_COMPRESSION[compression],
        )
        self._writer.start(profile="ros2", library=_LIBRARY)
        self._lock = threading.Lock()
        self._topics: dict[str, TopicInfo] = {}
        self._schemas: dict[str, int] = {}
        self._tally = MessageTally()
        self._finished = False
        #: The first I/O error of a write or a flush (None: none); every later write raises it.
        self.io_error: OSError | None = None
        # closes the chunks on the schedule; the flush thread compresses and writes them
        self._flusher = ChunkFlusher(
            self._writer, self._stream, self.path, self._lock, schedule, self._failed, flush_thread
        )
        self._appender = MessageAppender(self._writer, self._flusher.on_full())

    # ---- context manager --------------------------------------------------------------------
    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(self, *exc_info) -> None:
        self.finish()

    # ---- topics -----------------------------------------------------------------------------
    def register_topic(self, topic: str, msg_type, qos: Any = None) -> TopicInfo:
        """Declare a topic (schema + channel); registering the same topic again is a no-op.

        The schema data is the full definition generated from the installed interfaces
        (:func:`drs_ros.recording.msgdefs.full_definition`).

        Parameters
        ----------
        topic : str
            Absolute topic name, e.g. ``"/joint_states"``.
        msg_type : type or str
            Message class or ``pkg/msg/Type``.
        qos : rclpy.qos.QoSProfile or int or None
            Offered QoS (see :func:`qos_dict`); a list of profiles is accepted too.

        Returns
        -------
        TopicInfo
        """
        name = msgdefs.type_name(msg_type)
        cls = msgdefs.message_class(msg_type)
        profiles = [qos_dict(q) for q in (qos if isinstance(qos, (list, tuple)) else [qos])]
        # rosbags checks a channel's hash against the type it parses from the schema, and cannot
        # name a service type (it files pkg/srv/T under pkg/srv/msg/T): with the hash, rosbags
        # would refuse the whole bag, so a service event channel carries none
        type_hash = "" if msgdefs.is_service_event(name) else msgdefs.type_hash(name)
        return self._register(
            topic, name, cls, msgdefs.full_definition(name), "ros2msg", profiles, type_hash
        )

    def register_recorded_topic(
        self,
        topic: str,
        type_name: str,
        definition: bytes,
        schema_encoding: str,
        qos_profiles: list[dict[str, Any]],
        type_hash: str,
    ) -> TopicInfo:
        """Declare a topic copied from another bag (schema and channel metadata as they were);
        :meth:`write` then takes its messages as bytes only.

        Parameters
        ----------
        topic : str
            Absolute topic name.
        type_name : str
            The schema name (``pkg/msg/Type``).
        definition : bytes
            The schema data, copied verbatim.
        schema_encoding : str
            The schema encoding (``ros2msg``, ``ros2idl``...).
        qos_profiles : list of dict
            The offered QoS profiles (:func:`parse_qos_yaml` of the source channel).
        type_hash : str
            The source channel's ``topic_type_hash`` (``""`` if it had none).
        """
        return self._register(
            topic, type_name, None, definition, schema_encoding, qos_profiles, type_hash
        )

    def _register(self, topic, name, cls, definition, encoding, profiles, type_hash) -> TopicInfo:
        if not isinstance(topic, str) or not topic.startswith("/"):
            raise RecordingError(f"topic must be an absolute name starting with '/', got {topic!r}")
        data = definition.encode() if isinstance(definition, str) else bytes(definition)
        with self._lock:
            self._check_open()
            known = self._topics.get(topic)
            if known is not None:
                if known.type_name != name:
                    raise RecordingError(
                        f"topic {topic!r} is registered with type {known.type_name}, not {name}"
                    )
                return known
            schema_id = self._schemas.get(name)
            if schema_id is None:
                schema_id = self._writer.register_schema(name, encoding, data)
                self._schemas[name] = schema_id
            metadata = {"offered_qos_profiles": qos_yaml(list(profiles))}
            metadata["topic_type_hash"] = type_hash
            channel_id = self._writer.register_channel(topic, "cdr", schema_id, metadata)
            info = TopicInfo(topic, name, cls, channel_id, tuple(profiles), type_hash)
            self._topics[topic] = info
            self._tally.add_topic(topic)
            return info

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """Registered topics by name (a copy)."""
        with self._lock:
            return dict(self._topics)

    # ---- writing ----------------------------------------------------------------------------
    def write(
        self,
        topic: str,
        msg,
        log_time_ns: int,
        publish_time_ns: int | None = None,
        sequence: int | None = None,
    ) -> int:
        """Append one message (thread-safe); returns its sequence number on the channel.

        ``topic``: a registered topic; ``msg``: a message of its type (serialised exactly by
        :mod:`drs_ros.recording.cdr`) or its exact CDR bytes (as a raw subscription receives
        them); ``log_time_ns``: receive/record time [ns]; ``publish_time_ns``: send time [ns]
        (``log_time_ns`` when None); ``sequence``: the sequence number to store (a copied
        message keeps its own; by default one more than the channel's last).
        """
        data = self._data(topic, msg)
        log_ns = _time_ns(log_time_ns, "log_time_ns")
        pub_ns = log_ns if publish_time_ns is None else _time_ns(publish_time_ns, "publish_time_ns")
        with self._lock:
            self._check_open()
            seq = self._tally.count(topic, len(data), log_ns, sequence)
            self._appender.append(self._topics[topic].channel_id, log_ns, data, pub_ns, seq)
            closed = self._flusher.wrote_locked(self._tally.message_count)
        if closed:
            self._flusher.write_closed()
        return seq

    def write_many(self, records, log_time_ns: int) -> list[int]:
        """Append messages logged at one time (the states of a tick) under one lock: as
        :meth:`write` each, publish time = log time. ``records``: ``(topic, msg or bytes)``
        pairs; a bad one is refused before any is written. Returns their sequence numbers."""
        items = [(topic, self._data(topic, msg)) for topic, msg in records]
        log_ns = _time_ns(log_time_ns, "log_time_ns")
        with self._lock:
            self._check_open()
            topics, count = self._topics, self._tally.count
            batch = [
                (topics[topic].channel_id, data, count(topic, len(data), log_ns))
                for topic, data in items
            ]
            self._appender.append_many(log_ns, batch)  # the file's statistics updated once
            closed = self._flusher.wrote_locked(self._tally.message_count, len(items))
        if closed:
            self._flusher.write_closed()
        return [seq for _channel, _data, seq in batch]

    def _data(self, topic: str, msg) -> bytes:
        """The exact CDR of ``msg`` (a message of ``topic``'s type, or its bytes)."""
        info = self._topics.get(topic)
        if info is None:
            raise RecordingError(
                f"topic {topic!r} is not registered; registered: {sorted(self._topics)}"
            )
        if isinstance(msg, (bytes, bytearray, memoryview)):
            return bytes(msg)
        if info.msg_class is not None and type(msg) is info.msg_class:
            return cdr.serializer(info.msg_class)(msg)
        raise RecordingError(
            f"topic {topic!r} carries {info.type_name}, got {type(msg).__module__}."
            f"{type(msg).__name__}"
        )

    def flush(self) -> None:
        """Close the chunk in progress and hand everything to the OS (no fsync); returns once
        every closed chunk is in the file."""
        with self._lock:
            if self._finished:
                return
            self._flusher.close_locked(self._tally.message_count)
        self._flusher.drain()

    def _failed(self, exc: OSError) -> None:
        self.io_error = self.io_error or exc

    def _check_open(self) -> None:
        if self._finished:
            raise RecordingError(f"the recorder of {str(self.path)!r} is finished")
        if self.io_error is not None:
            err = self.io_error
            raise OSError(err.errno, f"the bag failed earlier: {err.strerror}", err.filename)

    # ---- statistics -------------------------------------------------------------------------
    def stats(self) -> RecorderStats:
        """A snapshot of the counters (see :class:`RecorderStats`)."""
        with self._lock:
            return RecorderStats(
                messages=dict(self._tally.counts),
                message_count=self._tally.message_count,
                bytes_written=self._tally.bytes,
                file_bytes=self._flusher.file_bytes,
                flush_count=self._flusher.schedule.count,
                messages_flushed=self._flusher.schedule.messages_flushed,
                seconds_since_flush=self._flusher.schedule.age_s(),
                finished=self._finished,
            )

    def bag_metadata(self) -> dict[str, Any]:
        """rosbag2's ``BagMetadata`` (version 9) of what was written so far, as a dict."""
        with self._lock:
            return self._bag_metadata_locked()

    def _bag_metadata_locked(self) -> dict[str, Any]:
        tally = self._tally
        return bag_metadata(
            self._topics.values(),
            tally.counts,
            tally.message_count,
            tally.t_min,
            tally.t_max,
            self.path.name,
            self.custom_data,
            self.ros_distro,
        )

    def discard(self) -> None:
        """Close without finishing and delete the bag's files (a node that failed to start);
        the directory itself is the caller's to remove."""
        with self._lock:
            self._finished = True
            self._flusher.stop()
            self._stream.close()
        for path in (self.path, self.metadata_path):
            path.unlink(missing_ok=True)

    def abandon(self) -> None:
        """Close a failed file as it is, without a summary or ``metadata.yaml`` (idempotent):
        what was flushed stays, for ``drs-bag recover``."""
        with self._lock:
            self._finished = True
            self._flusher.stop()
            self._stream.close()

    # ---- finish -----------------------------------------------------------------------------
    def finish(self) -> Path:
        """Write the metadata record, summary and footer, close the file, write ``metadata.yaml``.

        Idempotent: later calls do nothing. Returns the bag directory. Raises
        :class:`RecordingError` naming what could not be written (the summary and footer,
        ``metadata.yaml``) and why; ``metadata.yaml`` is written even when the summary failed.
        """
        missing = []
        with self._lock:
            if self._finished:
                return self.bag_dir
            self._finished = True
            self._flusher.stop()
            meta = self._bag_metadata_locked()
            try:
                self._flusher.close_locked(self._tally.message_count)
            except OSError as exc:
                missing.append(f"its summary and footer ({exc.strerror or exc})")
        try:
            self._flusher.drain()  # the chunks closed and not yet written, in order
        except OSError as exc:
            missing.append(f"its summary and footer ({exc.strerror or exc})")
        with self._lock:
            try:
                if not missing:  # a summary after a chunk that failed would index what is not
                    self._flusher.check_file()
                    self._writer.add_metadata(
                        "rosbag2", {"serialized_metadata": yaml.safe_dump(meta, sort_keys=False)}
                    )
                    self._writer.finish()
                    self._flusher.file_bytes = self._stream.tell()
            except OSError as exc:
                missing.append(f"its summary and footer ({exc.strerror or exc})")
            finally:
                self._stream.close()
            try:
                self.metadata_path.write_text(
                    yaml.safe_dump({"rosbag2_bagfile_information": meta}, sort_keys=False)
                )
            except OSError as exc:
                missing.append(f"{self.metadata_path.name} ({exc.strerror or exc})")
        self._flusher.join()
        if missing:
            raise RecordingError(
                f"bag {str(self.bag_dir)!r} is incomplete: {' and '.join(missing)} could not be "
                "written"
            )
        return self.bag_dir


def _time_ns(value, name: str) -> int:
    if isinstance(value, bool):
        raise RecordingError(f"{name} must be an int [ns], got {value!r}")
    try:
        value = operator.index(value)  # int and numpy integers
    except TypeError:
        raise RecordingError(f"{name} must be an int [ns], got {value!r}") from None
    if not 0 <= value < 2**64:
        raise RecordingError(f"{name} must lie in [0, 2**64) ns, got {value!r}")
    return value


__all__ = [
    "McapRecorder",
    "RecorderStats",
]
