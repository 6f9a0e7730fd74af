"""The in-place SetBool_Event check against ``cdr_received.exact_bytes`` (rclpy's decoder, the
serialiser, the comparison): for any bytes, the same exact CDR or the same refusal; and the
events as rcl and the serialiser write them taken in place, without the decoder."""

from __future__ import annotations

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

from std_srvs.srv import SetBool  # noqa: E402

from drs_ros.node import service_event_cdr  # noqa: E402
from drs_ros.node.service_event_cdr import exact_set_bool_event  # noqa: E402
from drs_ros.recording import cdr, cdr_received  # noqa: E402

SERIALIZE = cdr.serializer(SetBool.Event)


@st.composite
def events(draw) -> SetBool.Event:
    """A SetBool_Event as a service's introspection fills it: any event type, stamp, client and
    sequence number; the request, the response, both or neither; any message text."""
    ev = SetBool.Event()
    ev.info.event_type = draw(st.integers(0, 255))
    ev.info.stamp.sec = draw(st.integers(-(2**31), 2**31 - 1))
    ev.info.stamp.nanosec = draw(st.integers(0, 2**32 - 1))
    ev.info.client_gid = list(draw(st.binary(min_size=16, max_size=16)))
    ev.info.sequence_number = draw(st.integers(-(2**63), 2**63 - 1))
    if draw(st.booleans()):
        ev.request.append(SetBool.Request(data=draw(st.booleans())))
    if draw(st.booleans()):
        chars = st.characters(exclude_characters="\0", exclude_categories=("Cs",))
        text = draw(st.text(chars, max_size=40))
        ev.response.append(SetBool.Response(success=draw(st.booleans()), message=text))
    return ev


@st.composite
def wires(draw) -> bytes:
    """An event's exact CDR as the transport may deliver it (up to 3 zero bytes after), or with
    a byte changed to any value (padding, a boolean, a count, a length), cut short, or followed by
    stray bytes."""
    ev = draw(events())
    data = bytearray(SERIALIZE(ev))
    data += bytes(draw(st.integers(0, 3)))
    how = draw(st.sampled_from(["as sent", "a byte", "a byte", "a boolean", "cut", "stray tail"]))
    if how == "a byte":
        data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
    elif how == "a boolean" and (ev.request or ev.response):
        # the request's data at byte 48; the response's success after the two counts
        at = 48 if ev.request else 52
        if not ev.request or (ev.response and draw(st.booleans())):
            at = 56 if ev.request else 52
        data[at] = draw(st.integers(2, 255))
    elif how == "cut":
        del data[draw(st.integers(0, len(data) - 1)) :]
    elif how == "stray tail":
        data += draw(st.binary(min_size=1, max_size=6))
    return bytes(data)


def _event(request: bool, message: str | None) -> bytes:
    ev = SetBool.Event()
    ev.info.sequence_number = 3
    if request:
        ev.request.append(SetBool.Request(data=True))
    if message is not None:
        ev.response.append(SetBool.Response(success=True, message=message))
    return SERIALIZE(ev)


def _two_requests() -> bytes:
    """Two requests (the bound is one), each a valid boolean, then no response."""
    one = _event(True, None)  # ... the request count at byte 44, its boolean at 48
    return one[:44] + (2).to_bytes(4, "little") + b"\x01\x00" + bytes(2) + bytes(4)


def _nul_inside() -> bytes:
    data = bytearray(_event(False, "abxc"))
    data[data.index(b"abxc") + 2] = 0
    return bytes(data)


def _empty_string() -> bytes:
    """A message string of length 0 (no NUL): the serialiser writes "" as length 1 and a NUL."""
    data = _event(False, "")
    return data[:-5] + bytes(4)


def _outcome(check, data: bytes):
    try:
        return "taken", check(data)
    except cdr.CdrError as exc:
        return "refused", str(exc)


@settings(max_examples=600, deadline=None)
@given(data=wires())
@example(data=_two_requests())
@example(data=_nul_inside())
@example(data=_empty_string())
def test_every_wire_is_taken_or_refused_as_exact_bytes_does(data):
    ours = _outcome(exact_set_bool_event, data)
    assert ours == _outcome(lambda d: cdr_received.exact_bytes(d, SetBool.Event), data)


def _no_decoder(data, msg_class):
    raise AssertionError("the event went to exact_bytes")


@settings(max_examples=200, deadline=None)
@given(ev=events(), padding=st.integers(0, 3))
def test_an_exact_event_is_taken_in_place_without_the_decoder(ev, padding):
    exact = SERIALIZE(ev)
    with pytest.MonkeyPatch.context() as mp:  # the decoder unusable: taken in place, or fails
        mp.setattr(service_event_cdr.cdr_received, "exact_bytes", _no_decoder)
        assert exact_set_bool_event(exact + bytes(padding)) == exact


def test_padding_that_is_not_zero_goes_to_the_decoder_and_is_refused(monkeypatch):
    ev = SetBool.Event()
    ev.request.append(SetBool.Request(data=True))
    data = bytearray(SERIALIZE(ev))
    data[5] = 0x7F  # between info.event_type (byte 4) and info.stamp (aligned to 4 from byte 4)
    asked, exact_bytes = [], cdr_received.exact_bytes

    def decoder(data, msg_class):
        asked.append(data)
        return exact_bytes(data, msg_class)

    monkeypatch.setattr(service_event_cdr.cdr_received, "exact_bytes", decoder)
    with pytest.raises(cdr.CdrError, match="plus at most 3 zero bytes"):
        exact_set_bool_event(bytes(data))
    assert asked == [bytes(data)]


def test_an_event_rclpy_serialised_is_judged_as_exact_bytes_judges_it():
    """rclpy's serialiser (rmw's typesupport) may leave alignment padding uninitialised: the
    outcome is exact_bytes's, whatever the bytes hold."""
    from rclpy.serialization import serialize_message

    ev = SetBool.Event()
    ev.info.event_type = 1
    ev.info.sequence_number = 7
    ev.response.append(SetBool.Response(success=True, message="opening to 0.046 m in 0.01 s"))
    for _ in range(20):
        wire = serialize_message(ev)[: len(SERIALIZE(ev))]  # bytes after the CDR: docs/ros.md
        assert _outcome(exact_set_bool_event, wire) == _outcome(
            lambda d: cdr_received.exact_bytes(d, SetBool.Event), wire
        )
