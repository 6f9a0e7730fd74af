"""A std_msgs/Float64 command (``~/stroke_cmd``, ``~/force_cmd``) read in place from its CDR
bytes, for the real-time node.

Why: rclpy's ``deserialize_message`` and the serialiser that gives back the exact CDR take ~13 us a
command between them, on the executor thread that the tick waits for; a flood of commands spends a
core on it. Twelve bytes of plain little-endian CDR (the header and one double, then at most 3 zero
bytes of transport padding) are read here with one ``struct`` call (~2 us). Anything else, a
big-endian header, encapsulation options, bytes of another length, goes to
:func:`drs_ros.recording.cdr_received.decode_exact`, which decodes or refuses it: both ways give the
same message, the same exact bytes and the same :class:`~drs_ros.recording.cdr.CdrError`.
"""

from __future__ import annotations

import struct

from std_msgs.msg import Float64

from ..recording import cdr, cdr_received

_DOUBLE = struct.Struct("<d")
#: The exact CDR's length [bytes]: the encapsulation header and the double.
EXACT_LEN = len(cdr.CDR_LE_HEADER) + _DOUBLE.size


def read_float64(data: bytes) -> tuple[Float64, bytes]:
    """``(message, its exact CDR)`` of ``data`` as a raw subscription received it: what
    :func:`drs_ros.recording.cdr_received.decode_exact` returns or raises for it (module
    docstring)."""
    plain = data[:4] == cdr.CDR_LE_HEADER and len(data) >= EXACT_LEN
    if plain and cdr_received.is_transport_padding(data[EXACT_LEN:]):
        (value,) = _DOUBLE.unpack_from(data, 4)
        # packed again, as the serialiser packs the decoded value: the same bytes
        return Float64(data=value), cdr.CDR_LE_HEADER + _DOUBLE.pack(value)
    return cdr_received.decode_exact(data, Float64)
