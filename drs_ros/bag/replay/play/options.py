"""The options of ``drs-bag play`` (``ros2 bag play``'s names and meanings, see
:mod:`drs_ros.bag.replay.play`), checked once into :class:`PlayOptions`; and the player's error and
warning lines.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass

from drs_ros.errors import UsageError

PROG = "drs-bag play"
#: rosbag2's default ``--read-ahead-queue-size``.
DEFAULT_READ_AHEAD = 1000
#: rosbag2's ``--clock`` rate when the option is given without a value [Hz].
DEFAULT_CLOCK_HZ = 40.0
#: Default ``--wait-for-all-acked`` [ms] (rosbag2: -1, no wait).
DEFAULT_WAIT_ACKED_MS = 1000


class PlayError(UsageError):
    """An option of ``drs-bag play`` is invalid (rate <= 0, malformed remap...)."""


def error_line(exc: BaseException) -> str:
    """The one stderr line of a failed play (shared wording with the other ``drs-bag`` verbs)."""
    return f"{PROG}: error: {exc}"


def warn(text: str) -> None:
    """One warning line on stderr."""
    print(f"{PROG}: warning: {text}", file=sys.stderr, flush=True)


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
    node: str | None = None
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
        node=args.node,
        clock_hz=args.clock or 0.0,
        remap=tuple(args.remap or ()),
        read_ahead=args.read_ahead_queue_size,
        wait_acked_ms=args.wait_for_all_acked,
        wait_for_subscribers=args.wait_for_subscribers,
        qos_overrides_path=args.qos_profile_overrides_path,
        progress=sys.stderr.isatty(),
        stats_json=args.stats_json,
    )


# ---- command line -------------------------------------------------------------------------------
def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``play`` arguments (``ros2 bag play``'s names) to ``parser``, in this order:
    the bag and its timing, the topics and the clock, the delivery."""
    parser.add_argument("bag", help="bag directory or .mcap file")
    _add_timing_arguments(parser)
    _add_topic_arguments(parser)
    _add_delivery_arguments(parser)


def _add_timing_arguments(parser: argparse.ArgumentParser) -> None:
    """``--rate``, ``--loop``, ``--start-offset``, ``--delay``."""
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


def _add_topic_arguments(parser: argparse.ArgumentParser) -> None:
    """``--topics``, ``--node``, ``--clock``, ``--remap``: what is played, on which names."""
    parser.add_argument(
        "--topics",
        nargs="+",
        action="extend",
        metavar="TOPIC",
        help="play only these topics (recorded names)",
    )
    parser.add_argument(
        "--node",
        default=None,
        metavar="NAME",
        help="play only the topics of this drs node (its fully qualified name or its name), as "
        "the bag recorded them (with --topics: those of them); not in ros2 bag play",
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


def _add_delivery_arguments(parser: argparse.ArgumentParser) -> None:
    """The read-ahead queue, the waits for subscribers and acknowledgements, the QoS overrides."""
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
