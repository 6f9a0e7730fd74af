"""How a vehicle stack names a drs node in the tests: ``--ros-args`` remaps (``-r FROM:=TO``)
that put the node in car 7's namespace as its rear actuator and move its topics there."""

from __future__ import annotations

from collections.abc import Mapping

#: The rear actuator of car 7 as a stack names it: its namespace and node name.
REAR_NAMING = {"__ns": "/car7", "__node": "drs_rear"}
#: Where the stack moves the rear actuator's topics: an absolute one (the joint states) and
#: private ones (the piston force, the piston-side pressure).
REAR_TOPICS = {
    "/joint_states": "/car7/joint_states",
    "~/piston_force": "/car7/rear_force",
    "~/pressure_piston_side": "/car7/rear_pressure_a",
}


def remap_args(remaps: Mapping[str, str]) -> list[str]:
    """``-r FROM:=TO`` for each of ``remaps`` (FROM -> TO), as ``--ros-args`` items."""
    return [item for old, new in remaps.items() for item in ("-r", f"{old}:={new}")]
