"""The in-place Float64 reader against ``cdr_received.decode_exact`` (rclpy's decoder and the
serialiser): for any bytes, the same message and exact CDR, or the same refusal."""

from __future__ import annotations

import math
import struct

from hypothesis import given, settings
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

from std_msgs.msg import Float64  # noqa: E402

from drs_ros.node.float64_cdr import EXACT_LEN, read_float64  # noqa: E402
from drs_ros.recording import cdr, cdr_received  # noqa: E402

HEADERS = st.sampled_from(
    [cdr.CDR_LE_HEADER, b"\x00\x00\x00\x00", b"\x00\x01\x00\x03", b"\x00\x01", b""]
)


@st.composite
def wires(draw) -> bytes:
    """Bytes as a subscription may receive them: a header (little- or big-endian, options set,
    cut), a double (any bit pattern: NaN payloads, -0.0, infinities), then a tail (transport
    padding, stray bytes), or any bytes at all."""
    if draw(st.booleans()):
        return draw(st.binary(max_size=20))
    body = struct.pack("<Q", draw(st.integers(0, 2**64 - 1)))
    body = body[: draw(st.sampled_from([8, 8, 8, 7, 0]))]
    tail = draw(st.sampled_from([b"", b"", b"\x00", b"\x00\x00\x00", b"\x00" * 4, b"\x01"]))
    return draw(HEADERS) + body + tail


def _outcome(decode, data: bytes):
    try:
        msg, exact = decode(data)
    except cdr.CdrError as exc:
        return "refused", str(exc)
    assert isinstance(msg, Float64)
    return struct.pack("<d", msg.data), exact


@settings(max_examples=400, deadline=None)
@given(data=wires())
def test_every_wire_reads_as_decode_exact_reads_it(data):
    ours = _outcome(read_float64, data)
    assert ours == _outcome(lambda d: cdr_received.decode_exact(d, Float64), data)
    if ours[0] != "refused":
        assert len(ours[1]) == EXACT_LEN


def test_a_nan_payload_and_negative_zero_keep_their_bits():
    for bits in (0x7FF8_0000_0000_0001, 0xFFF4_0000_0000_0000, 0x8000_0000_0000_0000):
        data = cdr.CDR_LE_HEADER + struct.pack("<Q", bits) + b"\x00\x00"
        msg, exact = read_float64(data)
        assert exact == data[:EXACT_LEN]
        assert struct.pack("<d", msg.data) == data[4:EXACT_LEN]
        assert math.isnan(msg.data) or math.copysign(1.0, msg.data) == -1.0
