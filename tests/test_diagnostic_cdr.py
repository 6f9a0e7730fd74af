"""The direct DiagnosticArray packer (drs_ros.recording.diagnostic_cdr) against the generic CDR
engine (``cdr.serializer``) and rclpy's decoder (Fast CDR, an independent implementation), over
drawn texts (empty, long, non-ASCII, control characters and NULs), levels, stamps and shapes;
and the effect record's and diagnostics' statuses (drs_ros.conversions) in the form the bag
tools read (``outcome`` first, each value as ``str()`` gives it)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402

from drs_ros.conversions import (  # noqa: E402
    command_event_msg,
    command_event_status,
    diagnostics_status,
)
from drs_ros.recording import cdr  # noqa: E402
from drs_ros.recording.diagnostic_cdr import Status, diagnostic_array_cdr  # noqa: E402
from drs_ros.timestamps import ns_of, split_ns  # noqa: E402

SERIALIZE = cdr.serializer(DiagnosticArray)
#: builtin_interfaces/Time's range [ns]: int32 seconds.
STAMP_MIN, STAMP_MAX = -(2**31) * 10**9, 2**31 * 10**9 - 1

# short texts of any characters (NUL and control characters included, surrogates excluded:
# they are no UTF-8), and long ones, which move every later field's alignment
texts = st.one_of(st.text(max_size=12), st.text(min_size=100, max_size=700))
levels = st.one_of(
    st.sampled_from(
        [DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR, DiagnosticStatus.STALE]
    ),
    st.integers(0, 255).map(lambda i: bytes([i])),
)
stamps = st.one_of(st.just(0), st.just(STAMP_MAX), st.integers(STAMP_MIN, STAMP_MAX))
statuses = st.lists(
    st.builds(Status, levels, texts, texts, texts, st.lists(st.tuples(texts, texts), max_size=6)),
    max_size=4,
)


def rclpy_message(stamp_ns: int, frame_id: str, sts: list[Status]) -> DiagnosticArray:
    """The equivalent rclpy message, built field by field with rclpy's own classes."""
    arr = DiagnosticArray()
    arr.header.stamp.sec, arr.header.stamp.nanosec = split_ns(stamp_ns)
    arr.header.frame_id = frame_id
    for s in sts:
        status = DiagnosticStatus(
            level=s.level, name=s.name, message=s.message, hardware_id=s.hardware_id
        )
        status.values = [KeyValue(key=k, value=v) for k, v in s.values]
        arr.status.append(status)
    return arr


def c_string(text: str) -> str:
    """What a C reader (rclpy's decoder) gives back of a string: up to its first NUL."""
    return text.split("\x00", 1)[0]


@settings(max_examples=200, deadline=None)
@given(stamps, texts, statuses)
def test_packer_bytes_are_the_engines_and_rclpy_reads_them(stamp_ns, frame_id, sts):
    data = diagnostic_array_cdr(stamp_ns, sts, frame_id)
    assert data == SERIALIZE(rclpy_message(stamp_ns, frame_id, sts))
    back = deserialize_message(data, DiagnosticArray)
    assert ns_of(back.header.stamp) == stamp_ns
    assert back.header.frame_id == c_string(frame_id)
    assert len(back.status) == len(sts)
    for got, want in zip(back.status, sts, strict=True):
        assert got.level == want.level
        assert (got.name, got.message, got.hardware_id) == tuple(
            c_string(t) for t in (want.name, want.message, want.hardware_id)
        )
        assert [(kv.key, kv.value) for kv in got.values] == [
            (c_string(k), c_string(v)) for k, v in want.values
        ]


def test_every_alignment_of_a_count_after_a_string():
    """A status count and a values count after strings of 0..7 bytes (every padding 0..3):
    rclpy decodes each exactly (a fixed case beside the drawn ones)."""
    for n in range(8):
        for m in range(8):
            sts = [Status(DiagnosticStatus.WARN, "n" * n, "", "h" * m, [("k" * m, "v" * n)])]
            back = deserialize_message(diagnostic_array_cdr(7, sts, "f" * n), DiagnosticArray)
            assert back.header.frame_id == "f" * n
            assert back.status[0].hardware_id == "h" * m
            assert (back.status[0].values[0].key, back.status[0].values[0].value) == (
                "k" * m,
                "v" * n,
            )


values = st.dictionaries(
    st.text(max_size=8),
    st.one_of(st.integers(), st.floats(allow_nan=True), st.none(), st.booleans(), texts),
    max_size=6,
)


@settings(max_examples=100, deadline=None)
@given(stamps, texts, texts, levels, texts, values)
def test_effect_record_as_the_bag_tools_read_it(stamp_ns, source, outcome, level, reason, vals):
    """A record packed (what the node publishes and records) decodes to its documented form,
    and is the bytes of the message form (``command_event_msg``, which a re-simulated bag
    writes)."""
    data = diagnostic_array_cdr(
        stamp_ns, [command_event_status(source, outcome, level, reason, vals)]
    )
    assert data == SERIALIZE(command_event_msg(stamp_ns, source, outcome, level, reason, vals))
    (status,) = deserialize_message(data, DiagnosticArray).status
    assert status.name == c_string(source)
    assert status.hardware_id == "drs"
    assert status.message == c_string(f"{outcome}: {reason}" if reason else outcome)
    assert [(kv.key, kv.value) for kv in status.values] == [
        (c_string(k), c_string(v))
        for k, v in [("outcome", outcome), *((str(k), str(v)) for k, v in vals.items())]
    ]


def test_diagnostics_status_names_the_node_and_stringifies():
    vals = {"mode": "stroke", "ticks": 12, "gap_m": f"{math.pi:.9g}", "last_refusal": "none"}
    data = diagnostic_array_cdr(
        5, [diagnostics_status("drs", DiagnosticStatus.OK, "mode stroke", vals)]
    )
    (status,) = deserialize_message(data, DiagnosticArray).status
    assert status.name == "drs: actuator"
    assert {kv.key: kv.value for kv in status.values} == {
        "mode": "stroke",
        "ticks": "12",
        "gap_m": "3.14159265",
        "last_refusal": "none",
    }


@pytest.mark.parametrize(
    ("stamp_ns", "status", "what"),
    [
        (STAMP_MAX + 1, Status(DiagnosticStatus.OK, "", "", "", []), "'i' format"),
        (0, Status(b"\x00\x01", "", "", "", []), "level is one byte"),
        (0, Status(256, "", "", "", []), "format requires"),
        (0, Status(DiagnosticStatus.OK, "\ud800", "", "", []), "surrogate"),
        (0, Status(DiagnosticStatus.OK, "", "", "", [("k", 1.5)]), "encode"),
    ],
)
def test_refuses_what_is_no_diagnostic_array(stamp_ns, status, what):
    with pytest.raises(cdr.CdrError, match=what):
        diagnostic_array_cdr(stamp_ns, [status])
