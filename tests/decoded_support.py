"""A small bag read whole, for tests: every decoded message of the topics asked for kept in
memory (:func:`read_bag`), and the checks of ``drs-bag check`` run on them (:func:`check_bag`).

The product streams a bag instead (:func:`drs_ros.bag.read.decoded.stream_bag`,
:class:`drs_ros.bag.check.model_checks.ModelChecker`): memory does not grow with it.
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence
from pathlib import Path


def read_bag(path: str | Path, topics: Sequence[str], recover: bool = False):
    """Verify a whole bag and keep every decoded message of ``topics``
    (:func:`drs_ros.bag.read.decoded.stream_bag`, which says what it raises): a
    :class:`~drs_ros.bag.read.decoded.BagData` whose ``messages`` maps each topic to its
    ``(log_time_ns, message)`` in file order."""
    from drs_ros.bag.read.decoded import stream_bag

    messages: dict[str, list] = {t: [] for t in topics}
    data = stream_bag(
        path, topics, lambda topic, log, msg: messages[topic].append((log, msg)), recover
    )
    data.messages = messages
    return data


def check_bag(data, params=None, **options) -> list:
    """Run every check of ``drs-bag check`` on the messages of :func:`read_bag`
    (:class:`drs_ros.bag.check.model_checks.ModelChecker`, whose options ``options`` are), the
    topics
    merged by log time as a recorder interleaves them (each in its own order)."""
    from drs_ros.bag.check.model_checks import ModelChecker

    checker = ModelChecker(params, **options)
    streams = [
        [(log_ns, topic, msg) for log_ns, msg in msgs] for topic, msgs in data.messages.items()
    ]
    for log_ns, topic, msg in heapq.merge(*streams, key=lambda m: m[0]):
        checker.add(topic, log_ns, msg)
    return checker.results()
