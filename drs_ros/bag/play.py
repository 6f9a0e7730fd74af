"""``drs-bag play BAG``: publish a rosbag2 MCAP bag onto ROS 2 topics, like ``ros2 bag play``.

Every recorded message is published on its topic with its recorded type, at its recorded time
(``log_time`` deltas divided by ``--rate``), as the recorded serialised bytes (a raw publish: no
decode and re-encode). Options have ``ros2 bag play``'s names and meanings (rosbag2's
``ros2bag/verb/play.py`` and ``rosbag2_transport/player.cpp``):

* ``--rate R`` (> 0), ``--loop``, ``--start-offset S`` (seconds into the bag), ``--delay S``
  (sleep before play, each loop), ``--topics T [T ...]``, ``--remap OLD:=NEW [...]`` (node
  remapping rules, repeatable), ``--clock [HZ]`` (publish ``rosgraph_msgs/Clock`` on ``/clock`` at
  HZ wall-clock Hz, 40 when no value; a recorded ``/clock`` is then not played),
  ``--read-ahead-queue-size N`` (messages buffered ahead of the player, 1000), and
  ``--wait-for-all-acked MS`` (at the end, wait up to MS ms for reliable subscribers to
  acknowledge; 0 waits forever, negative does not wait). rosbag2 does not wait by default; this
  player waits up to 1000 ms, so the last messages of a run reach their subscribers.
* ``--wait-for-subscribers`` (not in ``ros2 bag play``): after ``--delay``, wait until every
  played topic (and ``/clock`` with ``--clock``) has a matched subscriber. DDS discovery on
  loopback took from 0.03 s to over 3 s here, so a fixed delay can lose the first messages.
* ``--qos-profile-overrides-path FILE``: a YAML mapping of recorded topic names to (partial)
  profiles in the ``offered_qos_profiles`` spelling, offered instead of the adapted ones
  (e.g. ``/joint_states: {depth: 1000}``).
* QoS: each topic's publisher offers what its recorders saw (channel metadata
  ``offered_qos_profiles``), adapted as ``Rosbag2QoS::adapt_offer_to_recorded_offers`` does: when
  all recorded offers agree on the policies that decide compatibility (reliability, durability,
  deadline, liveliness, lease duration), the first one with rosbag2's default history (keep last
  10); when they differ, or there is none, rosbag2's default offer (keep last 10, reliable,
  volatile), with a warning for the mixed case.

Memory stays bounded whatever the bag's size: the file is read chunk by chunk in log-time order
(``mcap``'s seeking reader loads a chunk only when its first message is due) by a reader thread
that stays at most ``--read-ahead-queue-size`` messages ahead. A file without chunk indexes is
read in file order (which rosbag2 writes in log-time order).

A topic whose type is not installed (or whose channel is not ``cdr``) is skipped with one warning
line. A missing, truncated, corrupt or non-MCAP bag ends the player with one line on stderr and
exit status 2. SIGINT or SIGTERM stop it cleanly (exit 0). On a terminal, a progress line shows
the bag time, the percentage played and the rate.

Exit status: 0 played (or stopped by a signal), 2 the bag cannot be read or an option is invalid.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import queue
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from drs_model.errors import DRSError

from .reader import BagReadError, resolve, scan

PROG = "drs-bag play"
#: rosbag2's default ``--read-ahead-queue-size``.
DEFAULT_READ_AHEAD = 1000
#: rosbag2's ``--clock`` rate when the option is given without a value [Hz].
DEFAULT_CLOCK_HZ = 40.0
#: Default ``--wait-for-all-acked`` [ms] (rosbag2: -1, no wait).
DEFAULT_WAIT_ACKED_MS = 1000
#: History depth of rosbag2's offers (``rmw_qos_profile_default.depth``).
DEFAULT_QOS_DEPTH = 10
#: ``RMW_DURATION_INFINITE`` [ns] and the Foxy-era spellings rosbag2 reads as infinite.
INFINITE_NS = 2**63 - 1
_FOXY_INFINITE = {(0x7FFFFFFF, 0xFFFFFFFF), (0x7FFFFFFF, 0x7FFFFFFF), divmod(INFINITE_NS, 10**9)}
CLOCK_TOPIC = "/clock"
#: The 8 bytes every MCAP file starts (and ends) with.
MCAP_MAGIC = b"\x89MCAP0\r\n"
PROGRESS_PERIOD_S = 0.25
#: Longest single sleep of the player [s] (bounds the reaction to a stop request).
MAX_SLEEP_S = 0.05


class PlayError(DRSError, ValueError):
    """An option of ``drs-bag play`` is invalid (rate <= 0, malformed remap...)."""


def error_line(exc: BaseException) -> str:
    """The one stderr line of a failed play (shared wording with the other ``drs-bag`` verbs)."""
    return f"{PROG}: error: {exc}"


def warn(text: str) -> None:
    """One warning line on stderr."""
    print(f"{PROG}: warning: {text}", file=sys.stderr, flush=True)


# ---- QoS ----------------------------------------------------------------------------------------
def _duration_ns(value: Any) -> int:
    """A recorded ``{sec, nsec}`` duration [ns]; rosbag2's infinite spellings -> infinite."""
    sec, nsec = int(value["sec"]), int(value["nsec"])
    if (sec, nsec) in _FOXY_INFINITE:
        return INFINITE_NS
    return min(sec * 10**9 + nsec, INFINITE_NS)


def _policy(enum_type, value: Any):
    """A policy from its metadata-version-9 name (``reliable``) or a version <= 8 integer."""
    if isinstance(value, bool):
        raise ValueError(f"invalid QoS policy {value!r}")
    if isinstance(value, int):
        return enum_type(value)
    return enum_type[str(value).strip().upper()]


def qos_profile(offer: dict[str, Any]):
    """An rclpy ``QoSProfile`` from one recorded offer (a dict of ``offered_qos_profiles``)."""
    from rclpy.duration import Duration
    from rclpy.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        LivelinessPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )

    history = _policy(HistoryPolicy, offer.get("history", "keep_last"))
    return QoSProfile(
        history=history,
        depth=int(offer.get("depth", DEFAULT_QOS_DEPTH)),
        reliability=_policy(ReliabilityPolicy, offer["reliability"]),
        durability=_policy(DurabilityPolicy, offer["durability"]),
        deadline=Duration(nanoseconds=_duration_ns(offer["deadline"])),
        lifespan=Duration(nanoseconds=_duration_ns(offer["lifespan"])),
        liveliness=_policy(LivelinessPolicy, offer["liveliness"]),
        liveliness_lease_duration=Duration(
            nanoseconds=_duration_ns(offer["liveliness_lease_duration"])
        ),
        avoid_ros_namespace_conventions=bool(offer.get("avoid_ros_namespace_conventions", False)),
    )


#: The keys of a profile in ``offered_qos_profiles`` and in a QoS overrides file.
QOS_KEYS = frozenset(
    {
        "history",
        "depth",
        "reliability",
        "durability",
        "deadline",
        "lifespan",
        "liveliness",
        "liveliness_lease_duration",
        "avoid_ros_namespace_conventions",
    }
)


def qos_overrides(path: str | Path) -> dict[str, Any]:
    """Topic -> QoSProfile from a ``--qos-profile-overrides-path`` YAML file.

    Each value is a partial profile (missing policies keep rclpy's defaults: keep last 10,
    reliable, volatile). Raises :class:`PlayError` on an unreadable file or an unknown key.
    """
    try:
        text = Path(path).read_text()
        table = yaml.safe_load(text) or {}
        if not isinstance(table, dict):
            raise TypeError("expected a mapping of topic names to profiles")
        out = {}
        for topic, given in table.items():
            unknown = set(given) - QOS_KEYS
            if unknown:
                raise KeyError(
                    f"{topic}: unknown QoS keys {sorted(unknown)}, valid: {sorted(QOS_KEYS)}"
                )
            base = {
                "history": "keep_last",
                "depth": DEFAULT_QOS_DEPTH,
                "reliability": "reliable",
                "durability": "volatile",
                "liveliness": "system_default",
            }
            zero = {"sec": 0, "nsec": 0}  # unspecified: the middleware's default
            for key in ("deadline", "lifespan", "liveliness_lease_duration"):
                base[key] = zero
            out[str(topic)] = qos_profile({**base, **given})
        return out
    except (OSError, yaml.YAMLError, TypeError, KeyError, ValueError, AttributeError) as exc:
        raise PlayError(
            f"--qos-profile-overrides-path {str(path)!r}: {type(exc).__name__}: {exc}"
        ) from exc


def default_qos():
    """rosbag2's default offer (``Rosbag2QoS{}``): keep last 10, reliable, volatile."""
    from rclpy.qos import QoSProfile

    return QoSProfile(depth=DEFAULT_QOS_DEPTH)


def playback_qos(offered_yaml: str | None, topic: str) -> tuple[Any, str | None]:
    """The QoS to offer when playing ``topic``, as rosbag2 adapts its recorded offers.

    Parameters
    ----------
    offered_yaml : str or None
        The channel metadata ``offered_qos_profiles`` (a YAML list), or None / empty.
    topic : str
        Topic name (for the warning).

    Returns
    -------
    (QoSProfile, str or None)
        The profile and a warning (mixed or unreadable offers), or None.
    """
    if not offered_yaml or not offered_yaml.strip():
        return default_qos(), None
    try:
        offers = yaml.safe_load(offered_yaml) or []
        profiles = [qos_profile(offer) for offer in offers]
    except (yaml.YAMLError, KeyError, ValueError, TypeError, AttributeError) as exc:
        return default_qos(), (
            f"topic {topic}: unreadable offered_qos_profiles ({type(exc).__name__}: {exc}); "
            "using the default QoS (keep last 10, reliable, volatile)"
        )
    if not profiles:
        return default_qos(), None

    def compat(p):
        return (
            p.reliability,
            p.durability,
            p.deadline.nanoseconds,
            p.liveliness,
            p.liveliness_lease_duration.nanoseconds,
        )

    if any(compat(p) != compat(profiles[0]) for p in profiles[1:]):
        return default_qos(), (
            f"topic {topic}: its recorded publishers offered different QoS profiles; "
            "using the default QoS (keep last 10, reliable, volatile), as rosbag2 does"
        )
    from rclpy.qos import HistoryPolicy

    chosen = profiles[0]
    chosen.history = HistoryPolicy.KEEP_LAST
    chosen.depth = DEFAULT_QOS_DEPTH
    return chosen, None


# ---- reading ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Channel:
    """A recorded topic: name, ``pkg/msg/Type``, message encoding, QoS metadata."""

    topic: str
    type_name: str
    encoding: str
    offered_qos: str | None


@dataclass(frozen=True)
class BagIndex:
    """What the summaries of a bag's files say: files, channels, time range [ns], count."""

    files: tuple[Path, ...]
    channels: dict[str, Channel]
    start_ns: int
    end_ns: int
    message_count: int


def _read_failure(path: Path, exc: Exception) -> BagReadError:
    return BagReadError(
        f"{str(path)!r}: not MCAP, truncated or corrupt ({type(exc).__name__}: "
        f"{str(exc) or 'end of file'})"
    )


def _summary(f, path: Path):
    """The summary of an open MCAP file (a seeking reader validating chunk CRCs)."""
    from mcap.reader import make_reader

    if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
        raise BagReadError(f"{str(path)!r}: not an MCAP file (no MCAP magic at its start)")
    f.seek(0)
    try:
        reader = make_reader(f, validate_crcs=True)
        reader.get_header()
        summary = reader.get_summary()
    except Exception as exc:  # any failure of the mcap library is a bad file, never a traceback
        raise _read_failure(path, exc) from exc
    if summary is None:
        raise BagReadError(
            f"{str(path)!r}: truncated or unfinished MCAP file (no summary); "
            "its readable prefix can be recovered (drs-bag recover)"
        )
    return reader, summary


def index_bag(path: str | Path) -> BagIndex:
    """Read the summaries of a bag's files: channels (first type wins), time range, count.

    Raises
    ------
    BagReadError
        Missing path, not MCAP, truncated (no summary) or corrupt.
    """
    files = resolve(path, require_metadata=False).files
    channels: dict[str, Channel] = {}
    start, end, count = INFINITE_NS, -1, 0
    for file in files:
        with open(file, "rb") as f:
            _reader, summary = _summary(f, file)
        for ch in summary.channels.values():
            schema = summary.schemas.get(ch.schema_id)
            channels.setdefault(
                ch.topic,
                Channel(
                    ch.topic,
                    schema.name if schema is not None else "",
                    ch.message_encoding,
                    ch.metadata.get("offered_qos_profiles"),
                ),
            )
        stats = summary.statistics
        if stats is not None and stats.message_count:
            start = min(start, stats.message_start_time)
            end = max(end, stats.message_end_time)
            count += stats.message_count
        for ci in summary.chunk_indexes:
            start = min(start, ci.message_start_time)
            end = max(end, ci.message_end_time)
    if end < 0:
        start = end = 0
    return BagIndex(files, channels, start, end, count)


def iter_bag(
    index: BagIndex, topics: Sequence[str], starting_at: int | None = None
) -> Iterator[tuple[str, int, bytes]]:
    """``(topic, log_time_ns, serialised bytes)`` of ``topics``, in log-time order per file.

    Streams: ``iter_messages(log_time_order=True)`` of the seeking reader decompresses a chunk
    only when its first message is the next one due, so memory holds the chunks overlapping in
    time, not the file. Without chunk indexes the file order is kept (no in-memory sort).
    """
    from mcap.reader import make_reader

    wanted = sorted(topics)
    for file in index.files:
        try:
            with open(file, "rb") as f:
                reader = make_reader(f, validate_crcs=True)
                summary = reader.get_summary()
                if summary is None:
                    raise BagReadError(f"{str(file)!r}: truncated or unfinished MCAP file")
                ordered = bool(summary.chunk_indexes)
                for _schema, channel, message in reader.iter_messages(
                    wanted, log_time_order=ordered, starting_at=starting_at
                ):
                    data = message.data
                    yield (
                        channel.topic,
                        message.log_time,
                        (data if isinstance(data, bytes) else bytes(data)),
                    )
        except DRSError:
            raise
        except Exception as exc:  # a corrupt chunk, found while playing
            raise _read_failure(file, exc) from exc


# ---- read-ahead ---------------------------------------------------------------------------------
_END = object()


class ReadAhead:
    """A reader thread that keeps at most ``size`` messages of ``source`` ready (rosbag2's
    read-ahead queue). Iterating yields them; a reader error is raised in the consumer.
    Setting ``stop`` (or :meth:`close`) ends both sides within 0.1 s."""

    def __init__(self, source: Iterator, size: int, stop: threading.Event | None = None):
        self._queue: queue.Queue = queue.Queue(maxsize=size)
        self._stop = stop if stop is not None else threading.Event()
        self._closed = threading.Event()
        self._thread = threading.Thread(
            target=self._fill, args=(source,), name="drs-bag-read-ahead", daemon=True
        )
        self._thread.start()

    def _put(self, item) -> bool:
        while not self._halted():
            try:
                self._queue.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def _fill(self, source: Iterator) -> None:
        try:
            for item in source:
                if not self._put(item):
                    return
            self._put(_END)
        except BaseException as exc:  # handed to the consumer, which reports it
            self._put(exc)
        finally:
            close = getattr(source, "close", None)
            if close is not None:
                close()

    def __iter__(self):
        while True:
            try:
                item = self._queue.get(timeout=0.1)
            except queue.Empty:
                if self._halted():
                    return
                continue
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            yield item

    def _halted(self) -> bool:
        return self._stop.is_set() or self._closed.is_set()

    def close(self) -> None:
        """Stop the reader thread (waits up to 1 s for it)."""
        self._closed.set()
        self._thread.join(timeout=1.0)


# ---- options ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PlayOptions:
    """Validated ``play`` options (see the module docstring; times in s, rates in Hz)."""

    bag: str
    rate: float = 1.0
    loop: bool = False
    start_offset_s: float = 0.0
    delay_s: float = 0.0
    topics: tuple[str, ...] = ()
    clock_hz: float = 0.0
    remap: tuple[str, ...] = ()
    read_ahead: int = DEFAULT_READ_AHEAD
    wait_acked_ms: int = DEFAULT_WAIT_ACKED_MS
    wait_for_subscribers: bool = False
    qos_overrides_path: str | None = None
    progress: bool = False
    stats_json: str | None = None

    def __post_init__(self):
        def finite(name, value, low, strict):
            ok = math.isfinite(value) and (value > low if strict else value >= low)
            if not ok:
                raise PlayError(f"--{name} must be {'>' if strict else '>='} {low}, got {value}")

        finite("rate", self.rate, 0.0, True)
        finite("start-offset", self.start_offset_s, 0.0, False)
        finite("delay", self.delay_s, 0.0, False)
        finite("clock", self.clock_hz, 0.0, False)
        if self.read_ahead < 1:
            raise PlayError(f"--read-ahead-queue-size must be >= 1, got {self.read_ahead}")
        for rule in self.remap:
            old, sep, new = rule.partition(":=")
            if not sep or not old or not new:
                raise PlayError(f"--remap rule must be OLD:=NEW, got {rule!r}")


def options_from_args(args: argparse.Namespace) -> PlayOptions:
    """:class:`PlayOptions` from parsed arguments (raises :class:`PlayError`)."""
    return PlayOptions(
        bag=args.bag,
        rate=args.rate,
        loop=args.loop,
        start_offset_s=args.start_offset,
        delay_s=args.delay,
        topics=tuple(args.topics or ()),
        clock_hz=args.clock or 0.0,
        remap=tuple(args.remap or ()),
        read_ahead=args.read_ahead_queue_size,
        wait_acked_ms=args.wait_for_all_acked,
        wait_for_subscribers=args.wait_for_subscribers,
        qos_overrides_path=args.qos_profile_overrides_path,
        progress=sys.stderr.isatty(),
        stats_json=args.stats_json,
    )


# ---- player -------------------------------------------------------------------------------------
class Player:
    """Publishes a bag with one rclpy node (see the module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        The node owning the publishers (remapping rules apply to it).
    index : BagIndex
        The bag.
    options : PlayOptions
    stop : threading.Event
        Set to stop playing (a signal).
    overrides : dict, optional
        Topic -> QoSProfile offered instead of the recorded offers (:func:`qos_overrides`).
    """

    def __init__(
        self,
        node,
        index: BagIndex,
        options: PlayOptions,
        stop: threading.Event,
        overrides: dict[str, Any] | None = None,
    ):
        from drs_ros.msgdefs import message_class

        self.node, self.index, self.options, self.stop = node, index, options, stop
        self.publishers: dict[str, Any] = {}
        self.stats: list[tuple[float, float]] = []
        self.published = 0
        wanted = set(options.topics) if options.topics else set(index.channels)
        overrides = overrides or {}
        for name in sorted(set(options.topics) - set(index.channels)):
            warn(f"topic {name} is not in the bag")
        for name in sorted(wanted & set(index.channels)):
            ch = index.channels[name]
            if options.clock_hz > 0 and name == CLOCK_TOPIC:
                warn(f"not playing the recorded {CLOCK_TOPIC}: --clock publishes it")
                continue
            if ch.encoding != "cdr":
                warn(f"skipping topic {name}: message encoding {ch.encoding!r} is not cdr")
                continue
            try:
                msg_class = message_class(ch.type_name)
            except DRSError as exc:
                warn(
                    f"skipping topic {name}: type {ch.type_name or '(no schema)'!r} is not "
                    f"installed ({exc})"
                )
                continue
            if name in overrides:
                qos = overrides[name]
            else:
                qos, note = playback_qos(ch.offered_qos, name)
                if note:
                    warn(note)
            try:
                self.publishers[name] = node.create_publisher(msg_class, name, qos)
            except Exception as exc:  # rclpy's own errors (type support, QoS, topic name)
                warn(f"skipping topic {name}: cannot publish {ch.type_name} ({exc})")
        self.clock_pub = None
        if options.clock_hz > 0:
            from rclpy.qos import QoSProfile, ReliabilityPolicy
            from rosgraph_msgs.msg import Clock

            self._clock_msg = Clock()
            # rclcpp::ClockQoS, as the rosbag2 player uses: keep last 1, best effort.
            self.clock_pub = node.create_publisher(
                Clock, CLOCK_TOPIC, QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
            )

    # -- time ----------------------------------------------------------------------------------
    def _publish_clock(self, bag_ns: int) -> None:
        stamp = self._clock_msg.clock
        stamp.sec, stamp.nanosec = divmod(int(bag_ns), 1_000_000_000)
        self.clock_pub.publish(self._clock_msg)

    def _progress(self, bag_ns: int, loop_no: int) -> None:
        span = max(self.index.end_ns - self.index.start_ns, 1)
        pct = 100.0 * min(max((bag_ns - self.index.start_ns) / span, 0.0), 1.0)
        loop = f"  loop {loop_no}" if self.options.loop else ""
        sys.stderr.write(
            f"\r[{PROG}] bag time {bag_ns / 1e9:.3f} s  {pct:5.1f} %  rate {self.options.rate:g}"
            f"{loop}  "
        )
        sys.stderr.flush()

    def _wait_until(self, wall_target: float, bag_of_wall, loop_no: int) -> bool:
        """Sleep until ``wall_target`` (monotonic [s]), publishing /clock and progress on the
        way; False if stopped."""
        while not self.stop.is_set():
            now = time.monotonic()
            if self.clock_pub is not None and now >= self._next_clock:
                self._publish_clock(bag_of_wall(now))
                self._next_clock = max(self._next_clock + 1.0 / self.options.clock_hz, now)
            if self.options.progress and now >= self._next_progress:
                self._progress(bag_of_wall(now), loop_no)
                self._next_progress = now + PROGRESS_PERIOD_S
            remaining = wall_target - now
            if remaining <= 0:
                return True
            wake = min(remaining, MAX_SLEEP_S)
            if self.clock_pub is not None:
                wake = min(wake, max(self._next_clock - now, 0.0))
            if self.options.progress:
                wake = min(wake, max(self._next_progress - now, 0.0))
            self.stop.wait(wake)
        return False

    def _wait_for_subscribers(self) -> bool:
        """Wait until every publisher has a matched subscription; False if stopped."""
        while not self.stop.is_set():
            pubs = [*self.publishers.values(), *([self.clock_pub] if self.clock_pub else [])]
            if all(pub.get_subscription_count() > 0 for pub in pubs):
                return True
            self.stop.wait(0.02)
        return False

    # -- play ----------------------------------------------------------------------------------
    def play(self) -> bool:
        """Play the bag once (or until stopped, with ``--loop``); False if stopped."""
        opts = self.options
        self._next_clock = self._next_progress = time.monotonic()
        loop_no = 0
        while not self.stop.is_set():
            loop_no += 1
            if not self._play_once(loop_no):
                return False
            if not opts.loop:
                return True
        return False

    def _play_once(self, loop_no: int) -> bool:
        opts = self.options
        start_ns = self.index.start_ns + int(round(opts.start_offset_s * 1e9))
        wall0 = time.monotonic() + opts.delay_s

        def bag_of_wall(now: float) -> int:
            return start_ns + int(max(now - wall0, 0.0) * opts.rate * 1e9)

        if not self._wait_until(wall0, bag_of_wall, loop_no):
            return False
        if opts.wait_for_subscribers and not self._wait_for_subscribers():
            return False
        wall0 = time.monotonic()
        source = iter_bag(self.index, list(self.publishers), starting_at=start_ns)
        reader = ReadAhead(source, opts.read_ahead, self.stop)
        try:
            for topic, log_ns, data in reader:
                target = wall0 + (log_ns - start_ns) / opts.rate / 1e9
                if not self._wait_until(target, bag_of_wall, loop_no):
                    return False
                actual = time.monotonic()
                self.publishers[topic].publish(data)
                self.published += 1
                if opts.stats_json is not None:
                    self.stats.append((target - wall0, actual - wall0))
        finally:
            reader.close()
        if self.stop.is_set():  # the reader ended early on a stop request
            return False
        if opts.progress:
            self._progress(self.index.end_ns, loop_no)
        return True

    def wait_for_acks(self) -> None:
        """rosbag2's ``--wait-for-all-acked``: wait for reliable subscribers' acknowledgements."""
        from rclpy.duration import Duration

        ms = self.options.wait_acked_ms
        if ms < 0:
            return
        deadline = None if ms == 0 else time.monotonic() + ms / 1000.0
        for pub in self.publishers.values():
            left = -1.0 if deadline is None else max(deadline - time.monotonic(), 0.0)
            pub.wait_for_all_acked(Duration(seconds=left))

    def write_stats(self) -> None:
        """Write ``{"rate", "offsets": [[scheduled, actual], ...]}`` [s from play start]."""
        if self.options.stats_json is None:
            return
        with open(self.options.stats_json, "w") as f:
            json.dump(
                {"rate": self.options.rate, "published": self.published, "offsets": self.stats}, f
            )


def play(options: PlayOptions) -> int:
    """Play a bag with ``options``; the exit status (0 played or stopped, 2 unreadable bag)."""
    index = index_bag(options.bag)  # fails before DDS starts
    path = options.qos_overrides_path
    overrides = qos_overrides(path) if path else {}
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import ExternalShutdownException
    from rclpy.signals import SignalHandlerOptions

    stop = threading.Event()
    previous = {
        sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)
    }
    context = Context()
    node = player = None
    try:
        rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
        cli_args = ["--ros-args"] + [a for rule in options.remap for a in ("-r", rule)]
        try:
            node = rclpy.create_node(
                "rosbag2_player", context=context, cli_args=cli_args if options.remap else None
            )
        except Exception as exc:  # rcl's RCLInvalidROSArgsError on a malformed --remap rule
            reason = str(exc).split(", at ")[0]
            raise PlayError(f"--remap {' '.join(options.remap)}: {reason}") from exc
        player = Player(node, index, options, stop, overrides)
        if player.play():
            player.wait_for_acks()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if options.progress:
            sys.stderr.write("\n")
        if player is not None:
            player.write_stats()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=context)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0


# ---- command line -------------------------------------------------------------------------------
def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``play`` arguments (``ros2 bag play``'s names) to ``parser``."""
    parser.add_argument("bag", help="bag directory or .mcap file")
    parser.add_argument(
        "-r",
        "--rate",
        type=_positive_float,
        default=1.0,
        help="rate at which to play back messages (> 0; default 1)",
    )
    parser.add_argument(
        "-l",
        "--loop",
        action="store_true",
        help="start again at the beginning on reaching the end, until SIGINT",
    )
    parser.add_argument(
        "--start-offset",
        type=float,
        default=0.0,
        metavar="S",
        help="start playback this many seconds into the bag",
    )
    parser.add_argument(
        "-d",
        "--delay",
        type=float,
        default=0.0,
        metavar="S",
        help="sleep before play (each loop) [s], so subscribers are discovered",
    )
    parser.add_argument(
        "--topics",
        nargs="+",
        action="extend",
        metavar="TOPIC",
        help="play only these topics (recorded names)",
    )
    parser.add_argument(
        "--clock",
        type=_positive_float,
        nargs="?",
        const=DEFAULT_CLOCK_HZ,
        default=0.0,
        metavar="HZ",
        help=f"publish /clock at HZ [Hz] (default {DEFAULT_CLOCK_HZ:g} when "
        "given without a value); the recorded /clock is then not played",
    )
    parser.add_argument(
        "-m",
        "--remap",
        nargs="+",
        action="extend",
        metavar="OLD:=NEW",
        help="remap topics, e.g. /joint_states:=/replay/joint_states (repeatable)",
    )
    parser.add_argument(
        "--read-ahead-queue-size",
        type=int,
        default=DEFAULT_READ_AHEAD,
        metavar="N",
        help=f"messages read ahead of the player (memory bound; default {DEFAULT_READ_AHEAD})",
    )
    parser.add_argument(
        "--wait-for-all-acked",
        type=int,
        default=DEFAULT_WAIT_ACKED_MS,
        metavar="MS",
        help="at the end, wait up to MS ms until reliable "
        "subscribers acknowledged every message (0: forever; < 0: no wait; "
        f"default {DEFAULT_WAIT_ACKED_MS})",
    )
    parser.add_argument(
        "--qos-profile-overrides-path",
        default=None,
        metavar="FILE",
        help="YAML file of topic: QoS profile overrides (offered_qos_profiles keys)",
    )
    parser.add_argument(
        "--wait-for-subscribers",
        action="store_true",
        help="after --delay, wait until every played topic has a matched subscriber "
        "(not in ros2 bag play)",
    )
    parser.add_argument("--stats-json", default=None, help=argparse.SUPPRESS)


def verify(path: str | Path) -> None:
    """Read the whole bag once, every file of a split bag, as ``drs-bag check`` does (CRCs,
    summary, ``metadata.yaml`` counts), so that a corrupt bag gets the same error before
    anything is published."""
    scan(path, exact=False)


def run(args: argparse.Namespace, prog: str = PROG) -> int:
    """Run ``play`` with parsed arguments; the exit status."""
    try:
        options = options_from_args(args)
        verify(args.bag)
        return play(options)
    except DRSError as exc:
        print(error_line(exc), file=sys.stderr)
        return 2


def main(argv: Sequence[str] | None = None) -> int:
    """``drs-bag play`` on its own (``python -m drs_ros.bag.play``)."""
    parser = argparse.ArgumentParser(
        prog=PROG, description="Publish a rosbag2 MCAP bag onto ROS 2 topics (ros2 bag play)."
    )
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
