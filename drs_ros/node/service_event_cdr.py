"""A ``~/drs`` call's introspection event (std_srvs/SetBool_Event), as the node's own
subscription to ``~/drs/_service_event`` receives it, checked in place before the bag takes it.

Why: the node records each event as its exact CDR,
:func:`drs_ros.recording.cdr_received.exact_bytes` (rclpy's decoder, the serialiser, a
comparison). On the executor thread, which wakes cold for each call, that took ~150 us of an
event's ~190 us, two events a call: nearly half of a ``~/drs`` call's CPU there (~30 us back to
back; benchmarks/results/node_rate.md, 2026-11-29). An event is read here in place, field by field,
by the serialisers' own rules (:class:`~drs_ros.recording.cdr_received.Reader`). Only bytes
that are already exact are taken this way: every alignment padding byte zero, each boolean 0 or
1, at most one request and one response (the sequences' bound), a UTF-8 message ending in its
one NUL, then at most the transport's zero padding. Any other bytes go to ``exact_bytes``, which
takes or refuses them: both ways give the same bytes or the same
:class:`~drs_ros.recording.cdr.CdrError`.
"""

from __future__ import annotations

import struct

from std_srvs.srv import SetBool

from ..recording import cdr_received
from ..recording.cdr import CdrError
from ..recording.cdr_received import Reader

_U8 = struct.Struct("<B")
_TIME = struct.Struct("<iI")  # builtin_interfaces/Time: sec, nanosec
_GID = struct.Struct("16s")  # service_msgs/ServiceEventInfo.client_gid: uint8[16]
_I64 = struct.Struct("<q")
#: The bound of SetBool_Event's request and response sequences.
SEQUENCE_BOUND = 1


def exact_set_bool_event(data: bytes) -> bytes:
    """The exact CDR of the SetBool_Event ``data`` (as a raw subscription received it): what
    :func:`drs_ros.recording.cdr_received.exact_bytes` returns or raises for it (module
    docstring)."""
    try:
        exact = _already_exact(data)
    except CdrError:  # its refusal, worded by the decoder: below
        exact = None
    return exact if exact is not None else cdr_received.exact_bytes(data, SetBool.Event)


def _already_exact(data: bytes) -> bytes | None:
    """``data`` without its transport padding if it is an exact SetBool_Event CDR; None (or a
    CdrError) when the decoder must decide."""
    r = Reader(data)
    r.read(_U8, 1, "info.event_type")
    r.read(_TIME, 4, "info.stamp")
    r.read(_GID, 1, "info.client_gid")
    r.read(_I64, 8, "info.sequence_number")
    requests = r.count("request")
    if requests > SEQUENCE_BOUND:
        return None
    if requests and r.read(_U8, 1, "request[0].data")[0] > 1:
        return None  # a boolean the serialiser would write as 1
    responses = r.count("response")
    if responses > SEQUENCE_BOUND:
        return None
    if responses:
        if r.read(_U8, 1, "response[0].success")[0] > 1:
            return None
        r.string("response[0].message")
    if not r.padding_is_zero:
        return None  # exact_bytes refuses padding that is not zero: let it say so
    return r.finish("SetBool_Event")


__all__ = ["SEQUENCE_BOUND", "exact_set_bool_event"]
