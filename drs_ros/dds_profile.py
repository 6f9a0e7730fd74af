"""The Fast DDS profile of drs's own processes (the node, its clients, ``drs-bag play``): faster
discovery's announcements, nothing else (``fastdds_discovery.xml``, beside this module).

A participant that starts after another is found by it only at the other's next announcement in
about half of the starts: Fast DDS's default period is 3 s, so a subscriber that ran before the
node received its first ``/joint_states`` 1.2-3.7 s after the node's exec instead of 1.1 s
(``benchmarks/node_vs_floor.py --startup``). With this profile the node announces itself every
0.5 s (the consumers started after it find it within that) and drs's clients do (a node started
after them is found within that). Processes that are not drs's keep their own settings: a stack
that wants the same for its nodes gives them this file (docs/ros.md, "Start-up").

Fast DDS reads the profile once per process, when its first participant is made: this must be
called before the process's first ``rclpy.init``.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping
from pathlib import Path

#: The profile file, installed with the package.
PROFILE_FILE = Path(__file__).with_name("fastdds_discovery.xml")

#: The variables by which Fast DDS (2.x and 3.x) is given a profile file.
PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")


def use_discovery_profile(environ: MutableMapping[str, str] | None = None) -> Path | None:
    """Name :data:`PROFILE_FILE` in ``environ`` (default ``os.environ``) for Fast DDS, and return
    it; None, changing nothing, when a profile file is named already (the user's wins) or the
    middleware is not Fast DDS (``RMW_IMPLEMENTATION`` naming another)."""
    environ = os.environ if environ is None else environ
    if any(environ.get(name) for name in PROFILE_VARIABLES):
        return None
    rmw = environ.get("RMW_IMPLEMENTATION", "")
    if rmw and not rmw.startswith("rmw_fastrtps"):
        return None
    environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(PROFILE_FILE)
    return PROFILE_FILE


__all__ = ["PROFILE_FILE", "PROFILE_VARIABLES", "use_discovery_profile"]
