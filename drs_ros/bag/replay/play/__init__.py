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
* ``--node NAME`` (not in ``ros2 bag play``): play only the topics of that drs node of the bag,
  by the names it recorded them under, remapped or not (:mod:`drs_ros.bag.read.nodes`); a topic it
  shares with other nodes (``/diagnostics``, ``/parameter_events``, ``/tf``) is played whole.
  A name that is no drs node of the bag is an error listing the ones it holds (exit status 2).
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

Play starts once the summaries of the bag's files are read (a few KiB at their ends), not after
reading the whole bag: each chunk's CRC is checked when it is played, and a corrupt chunk ends the
play there. A topic whose type is not installed (or whose channel is not ``cdr``) is skipped with
one warning line. A missing, truncated, corrupt or non-MCAP bag ends the player with one line on
stderr and exit status 2. SIGINT or SIGTERM stop it cleanly (exit 0). On a terminal, a progress
line shows the bag time, the percentage played and the rate.

Exit status: 0 played (or stopped by a signal), 2 the bag cannot be read or an option is invalid.

Modules: ``options`` (the command line), ``index`` (the bag's summaries and its messages in
log-time order), ``read_ahead`` (the bounded queue), ``offers`` (the QoS of each publisher),
``player`` (the player and the verb's ``run``/``main``). This module re-exports their public names.
"""

from drs_ros.bag.replay.play.index import index_bag, iter_bag
from drs_ros.bag.replay.play.offers import playback_qos, qos_overrides
from drs_ros.bag.replay.play.options import PlayError, PlayOptions, add_arguments
from drs_ros.bag.replay.play.player import main, play, run

__all__ = [
    "PlayError",
    "PlayOptions",
    "add_arguments",
    "index_bag",
    "iter_bag",
    "main",
    "play",
    "playback_qos",
    "qos_overrides",
    "run",
]
