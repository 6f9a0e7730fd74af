"""Non-zero CDR alignment padding (its content is unspecified; Fast DDS sends uninitialised
memory there and rclpy decodes such a message) is a note of every reader, not corruption:
``drs-bag check``, ``resimulate`` and ``recover`` read a bag whose padding is filled, and a real
difference from the exact CDR is still refused.

The padded bag is the example bag with the padding of three topics filled with 0xA5: the
padding is found without the code under test, as the zero bytes of a recorded message that
rclpy's decoder ignores (the message decodes equal with the byte changed), and every filled
message is checked to decode with rclpy to what the original decodes to.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from bag_support import copy_bags
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"
#: topic -> messages of it in the example bag: the topics whose padding is filled
FILLED = {"/drs/joint_reactions": 1679, "/diagnostics": 3, "/drs/drs/_service_event": 4}
FILL = 0xA5


def _rosbags_judge(type_name: str, schema: bytes) -> callable:
    """``same(data, changed)``: whether rosbags decodes ``changed`` to what ``data`` decodes to
    (its exact CDR again); a service event by its own schema, under rosbags' name for it."""
    from rosbags.typesys import Stores, get_typestore
    from rosbags.typesys.msg import get_types_from_msg

    store = get_typestore(Stores.ROS2_JAZZY)
    name = type_name
    if "/srv/" in type_name:
        store.register(get_types_from_msg(schema.decode(), type_name))
        name = type_name.replace("/srv/", "/srv/msg/")

    def same(data: bytes, changed: bytes) -> bool:
        try:
            return bytes(store.serialize_cdr(store.deserialize_cdr(changed, name), name)) == data
        except Exception:  # noqa: BLE001 - a byte the decoder needs: not padding
            return False

    return same


def ignored_zero_bytes(data: bytes, cls, rosbags_same) -> list[int]:
    """The zero bytes of ``data`` (after the encapsulation header) that neither rclpy's decoder
    nor rosbags' reads: the message decodes equal with the byte changed. Both, as rclpy (with
    these wheels) reads a sequence count it cannot honour as an empty sequence, with a line on
    stderr and no error."""
    from rclpy.serialization import deserialize_message

    ref = deserialize_message(data, cls)
    out = []
    for k in range(4, len(data)):
        if data[k] == 0:
            changed = bytearray(data)
            changed[k] = FILL
            try:
                same = deserialize_message(bytes(changed), cls) == ref
            except Exception:  # noqa: BLE001 - a byte the decoder needs: not padding
                same = False
            if same and rosbags_same(data, bytes(changed)):
                out.append(k)
    return out


@pytest.fixture(scope="module")
def padded_bag(tmp_path_factory) -> Path:
    require_rclpy()
    from rclpy.serialization import deserialize_message

    from drs_ros.bag.read.reader import scan
    from drs_ros.recording import msgdefs

    judges = {
        c.topic: _rosbags_judge(c.type_name, c.schema_data) for c in scan(EXAMPLE).channels.values()
    }
    filled: dict[str, int] = {}
    where: dict[tuple[str, int], list[int]] = {}  # (topic, length) -> padding offsets

    def fill(topic: str, type_name: str, data: bytes) -> bytes:
        if topic not in FILLED:
            return data
        cls = msgdefs.message_class(type_name)
        key = (topic, len(data))
        if key not in where:
            where[key] = ignored_zero_bytes(data, cls, judges[topic])
        out = bytearray(data)
        for k in where[key]:
            out[k] = FILL
        assert out != data
        # rclpy decodes the filled bytes to what it decodes the recorded ones to
        assert deserialize_message(bytes(out), cls) == deserialize_message(data, cls)
        filled[topic] = filled.get(topic, 0) + 1
        return bytes(out)

    bag = copy_bags([EXAMPLE], tmp_path_factory.mktemp("padding") / "padded", change=fill)
    assert filled == FILLED
    return bag


def _note(notes: list[str]) -> str:
    return next(n for n in notes if "alignment padding" in n)


def test_a_padded_bag_checks_with_a_note_naming_each_topic(padded_bag, capsys):
    from drs_ros.bag.check import command as check

    assert check.main([str(padded_bag), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    note = _note(report["notes"])
    for topic, n in FILLED.items():
        assert f"'{topic}': {n}" in note
    assert check.main([str(EXAMPLE), "--json"]) == 0  # the original: no such note
    assert not any("alignment padding" in n for n in json.loads(capsys.readouterr().out)["notes"])


def test_a_padded_bag_resimulates_as_the_original_does(padded_bag, capsys):
    from drs_ros.bag.cli import main

    reports = []
    for bag in (EXAMPLE, padded_bag):
        assert main(["resimulate", str(bag), "--json"]) == 0
        reports.append(json.loads(capsys.readouterr().out))
    assert reports[0]["signals"] == reports[1]["signals"]


def test_recover_copies_every_message_of_a_padded_bag(padded_bag, tmp_path, capsys):
    from drs_ros.bag.cli import main
    from drs_ros.bag.read.reader import scan

    assert main(["recover", str(padded_bag), "-o", str(tmp_path / "out"), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["complete_source"] and report["messages"] == sum(scan(EXAMPLE).counts.values())
    source, copy = [], []
    scan(padded_bag, lambda m: source.append((m.topic, m.log_time, m.data)))
    result = scan(tmp_path / "out", lambda m: copy.append((m.topic, m.log_time, m.data)))
    assert copy == source  # the filled bytes as they were
    assert "'/diagnostics': 3" in _note(result.notes)


def test_a_difference_beyond_the_padding_is_still_refused(padded_bag, tmp_path):
    """Bytes after a filled message, and a boolean byte of 2 (rclpy reads True, whose exact CDR
    is 1): not padding, refused by every reader."""
    require_rclpy()
    from std_msgs.msg import Bool

    from drs_ros.bag.read.files import BagReadError
    from drs_ros.bag.read.reader import scan
    from drs_ros.recording.cdr_padding import zero_padding
    from drs_ros.recording.mcap_recorder import McapRecorder

    leaked = copy_bags(
        [padded_bag],
        tmp_path / "leaked",
        change=lambda t, _n, d: d + b"\x7f" if t == "/diagnostics" else d,
    )
    with pytest.raises(BagReadError, match=r"message 1 of /diagnostics .* bytes where its CDR"):
        scan(leaked)
    two = b"\x00\x01\x00\x00\x02"
    assert zero_padding(two, Bool) == two  # no padding in it to zero
    with McapRecorder(tmp_path / "bool", flush_thread=False) as rec:
        rec.register_topic("/flag", Bool, 10)
        rec.write("/flag", two, 1)
    with pytest.raises(BagReadError, match=r"at byte 4, which is not alignment padding"):
        scan(tmp_path / "bool")


def test_the_padding_zeroed_is_what_two_independent_decoders_ignore():
    """For the first message of every topic of the example bag: the zero bytes that rclpy and
    rosbags both ignore, filled, are zeroed again by ``zero_padding``, and nothing else is
    changed; a count byte that rclpy alone ignores (it reads an impossible count of an empty
    sequence as empty) is not padding, and is refused."""
    require_rclpy()
    from drs_ros.bag.read.reader import scan
    from drs_ros.recording import cdr, msgdefs
    from drs_ros.recording.cdr_padding import zero_padding

    first = {}
    result = scan(EXAMPLE, lambda m: first.setdefault(m.topic, m))
    assert len(first) == len(result.counts)
    padded_types = 0
    for m in first.values():
        cls = msgdefs.message_class(m.type_name)
        where = ignored_zero_bytes(m.data, cls, _rosbags_judge(m.type_name, m.channel.schema_data))
        filled = bytearray(m.data)
        for k in where:
            filled[k] = FILL
        assert zero_padding(bytes(filled), cls) == m.data, m.topic
        padded_types += bool(where)
    assert padded_types >= 6  # JointState, DiagnosticArray, MarkerArray, ParameterEvent, ...
    events = first["/parameter_events"]
    cls = msgdefs.message_class(events.type_name)
    count = bytearray(events.data)
    count[97] = FILL  # a byte of new_parameters[0]'s string_array_value count (0)
    with pytest.raises(cdr.CdrError, match="string_array_value"):
        zero_padding(bytes(count), cls)
