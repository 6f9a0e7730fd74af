"""drs_model's time conversions (:mod:`drs_model.timebase`: integer nanoseconds, ``(sec,
nanosec)``, seconds, steps), under the name the node and the bag tools import them by."""

from __future__ import annotations

# ``NAME as NAME``: each name re-exported, listed once (PEP 484's explicit re-export)
from drs_model.timebase import NS_PER_S as NS_PER_S
from drs_model.timebase import T0_NS as T0_NS
from drs_model.timebase import nearest_step as nearest_step
from drs_model.timebase import nearest_steps as nearest_steps
from drs_model.timebase import ns_from_parts as ns_from_parts
from drs_model.timebase import ns_from_seconds as ns_from_seconds
from drs_model.timebase import ns_of as ns_of
from drs_model.timebase import seconds_from_ns as seconds_from_ns
from drs_model.timebase import set_ns as set_ns
from drs_model.timebase import split_ns as split_ns
from drs_model.timebase import steps_within as steps_within
