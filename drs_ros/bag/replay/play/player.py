"""The player of ``drs-bag play``: one rclpy node publishing a bag's messages at their recorded
times (see :mod:`drs_ros.bag.replay.play`), and the verb's entry (``run``, ``main``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence
from typing import Any

from drs_model.cli.exit_status import EXIT_OK, EXIT_UNREADABLE, EXIT_USAGE
from drs_model.cli.strict_parser import StrictParser
from drs_ros.bag.read.files import BagReadError
from drs_ros.bag.replay.play.index import BagIndex, index_bag, iter_bag
from drs_ros.bag.replay.play.offers import playback_qos, qos_overrides
from drs_ros.bag.replay.play.options import (
    PROG,
    PlayError,
    PlayOptions,
    add_arguments,
    error_line,
    options_from_args,
    warn,
)
from drs_ros.bag.replay.play.read_ahead import ReadAhead
from drs_ros.dds_profile import use_discovery_profile
from drs_ros.errors import UsageError
from drs_ros.stop_request import StopRequest
from drs_ros.timestamps import ns_from_seconds, seconds_from_ns, set_ns

CLOCK_TOPIC = "/clock"
PROGRESS_PERIOD_S = 0.25
#: Longest single sleep of the player [s] (bounds the reaction to a stop request).
MAX_SLEEP_S = 0.05


class Player:
    """Publishes a bag with one rclpy node (see the module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        The node owning the publishers (remapping rules apply to it).
    index : BagIndex
        The bag.
    options : PlayOptions
    stop : StopRequest
        Requested to stop playing (a signal); read between two messages and during waits.
    overrides : dict, optional
        Topic -> QoSProfile offered instead of the recorded offers (:func:`qos_overrides`).
    """

    def __init__(
        self,
        node,
        index: BagIndex,
        options: PlayOptions,
        stop: StopRequest,
        overrides: dict[str, Any] | None = None,
    ):
        from drs_ros.recording.msgdefs import MessageDefinitionError, message_class

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
            except MessageDefinitionError as exc:
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
        set_ns(self._clock_msg.clock, bag_ns)
        self.clock_pub.publish(self._clock_msg)

    def _progress(self, bag_ns: int, loop_no: int) -> None:
        span = max(self.index.end_ns - self.index.start_ns, 1)
        pct = 100.0 * min(max((bag_ns - self.index.start_ns) / span, 0.0), 1.0)
        loop = f"  loop {loop_no}" if self.options.loop else ""
        sys.stderr.write(
            f"\r[{PROG}] bag time {seconds_from_ns(bag_ns):.3f} s  {pct:5.1f} %  "
            f"rate {self.options.rate:g}{loop}  "
        )
        sys.stderr.flush()

    def _wait_until(self, wall_target: float, bag_of_wall, loop_no: int) -> bool:
        """Sleep until ``wall_target`` (monotonic [s]), publishing /clock and progress on the
        way; False if stopped."""
        while not self.stop.requested:
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
            time.sleep(wake)  # at most MAX_SLEEP_S: a stop is seen within it
        return False

    def _wait_for_subscribers(self) -> bool:
        """Wait until every publisher has a matched subscription; False if stopped."""
        while not self.stop.requested:
            pubs = [*self.publishers.values(), *([self.clock_pub] if self.clock_pub else [])]
            if all(pub.get_subscription_count() > 0 for pub in pubs):
                return True
            time.sleep(0.02)
        return False

    # -- play ----------------------------------------------------------------------------------
    def play(self) -> bool:
        """Play the bag once (or until stopped, with ``--loop``); False if stopped."""
        opts = self.options
        self._next_clock = self._next_progress = time.monotonic()
        loop_no = 0
        while not self.stop.requested:
            loop_no += 1
            if not self._play_once(loop_no):
                return False
            if not opts.loop:
                return True
        return False

    def _play_once(self, loop_no: int) -> bool:
        opts = self.options
        start_ns = self.index.start_ns + ns_from_seconds(opts.start_offset_s)
        # the wall time [s, monotonic] play began: until then (--delay, the wait for
        # subscribers) /clock holds the bag's start; it never runs ahead of the play and goes
        # back (a stall before the first message: a /clock 0.3 s on, then the start again)
        began: list[float] = []

        def bag_of_wall(now: float) -> int:
            if not began:
                return start_ns
            return start_ns + ns_from_seconds(max(now - began[0], 0.0) * opts.rate)

        if not self._wait_until(time.monotonic() + opts.delay_s, bag_of_wall, loop_no):
            return False
        if opts.wait_for_subscribers and not self._wait_for_subscribers():
            return False
        wall0 = time.monotonic()
        began.append(wall0)
        source = iter_bag(self.index, list(self.publishers), starting_at=start_ns)
        reader = ReadAhead(source, opts.read_ahead, self.stop)
        try:
            for topic, log_ns, data in reader:
                target = wall0 + seconds_from_ns(log_ns - start_ns) / opts.rate
                if not self._wait_until(target, bag_of_wall, loop_no):
                    return False
                actual = time.monotonic()
                self.publishers[topic].publish(data)
                self.published += 1
                if opts.stats_json is not None:
                    self.stats.append((target - wall0, actual - wall0))
        finally:
            reader.close()
        if self.stop.requested:  # the reader ended early on a stop request
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
    """Play a bag with ``options``; the exit status (0 played or stopped, 2 unreadable bag).

    The bag is indexed and rclpy imported first: a signal meanwhile (``drs-bag``'s console
    script ends at once while nothing is created, :mod:`drs_model.cli.start_signals`) does not
    wait for a second of imports. Then SIGINT and SIGTERM set a
    :class:`~drs_ros.stop_request.StopRequest` (a plain flag: an ``Event.set`` in the handler
    takes a lock that the main thread may hold inside ``Event.wait`` when the handler runs there,
    a deadlock); the player reads it between two messages and in every wait (at most
    ``MAX_SLEEP_S``)."""
    prepared = _prepare(options)
    stop = StopRequest()
    previous = stop.install()  # before DDS starts: a signal from here on is a stop
    try:
        return _play(prepared, stop)
    finally:
        stop.restore(previous)


def _prepare(options: PlayOptions) -> tuple[PlayOptions, BagIndex, dict]:
    """The bag indexed (it fails before DDS starts), ``--node``'s topics, the QoS overrides,
    and rclpy imported: (options, index, overrides)."""
    index = index_bag(options.bag)
    if options.node is not None:
        options = node_options(options, index)
    path = options.qos_overrides_path
    overrides = qos_overrides(path) if path else {}
    import rclpy  # noqa: F401 - imported before the stop is taken (play)

    return options, index, overrides


def _play(prepared: tuple[PlayOptions, BagIndex, dict], stop: StopRequest) -> int:
    options, index, overrides = prepared
    if stop.requested:
        return EXIT_OK
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    use_discovery_profile()  # subscribers started after the player find it within 0.5 s
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import ExternalShutdownException
    from rclpy.signals import SignalHandlerOptions

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
    return EXIT_OK


def node_options(options: PlayOptions, index: BagIndex) -> PlayOptions:
    """``options`` playing only the topics of the drs node ``--node`` names (of ``--topics``, if
    given), by the names the bag recorded them under (:mod:`drs_ros.bag.read.nodes`)."""
    import dataclasses

    from drs_ros.bag.read.nodes import find_node

    node = find_node(options.bag, options.node)
    topics = [t for t in dict.fromkeys(node.topics.values()) if t in index.channels]
    if options.topics:
        topics = [t for t in topics if t in options.topics]
    if not topics:
        raise PlayError(
            f"--node {options.node}: {node.name} has no recorded topic to play"
            + (" among --topics" if options.topics else "")
        )
    return dataclasses.replace(options, topics=tuple(sorted(topics)))


def run(args: argparse.Namespace, prog: str = PROG) -> int:
    """Run ``play`` with parsed arguments; the exit status."""
    try:
        options = options_from_args(args)
        # no reading ahead of the whole bag: the summaries are read before DDS starts, every
        # chunk's CRC as it is played (a corrupt chunk ends the play then, exit status 2)
        return play(options)
    except UsageError as exc:  # an option, --node's included (argparse's usage status)
        print(error_line(exc), file=sys.stderr)
        return EXIT_USAGE
    except BagReadError as exc:
        print(error_line(exc), file=sys.stderr)
        return EXIT_UNREADABLE


def main(argv: Sequence[str] | None = None) -> int:
    """``drs-bag play`` on its own (``python -m drs_ros.bag.replay.play``)."""
    parser = StrictParser(
        prog=PROG, description="Publish a rosbag2 MCAP bag onto ROS 2 topics (ros2 bag play)."
    )
    add_arguments(parser)
    return run(parser.parse_args(argv))
