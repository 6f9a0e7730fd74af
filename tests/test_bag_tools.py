"""Recordings judged by readers we did not write, and the drs-bag tools (info, check, recover).

* every message of the example bag and of a bag the node records now decodes with rosbags and
  with mcap_ros2, and rosbags' serialisation of it is the recorded bytes, byte for byte;
* service events, whose type name neither reader accepts (rosbags files pkg/srv/T under
  pkg/srv/msg/T, mcap_ros2 refuses '_' in a name), are decoded by rosbags from the bag's own
  schema text registered under rosbags' name, and by rclpy's type support;
* corruptions: drs-bag check exits non-zero with one line, never a traceback, never PASS;
* SIGKILL mid-motion, then drs-bag recover: every reader reads the result, and the lost tail is
  at most flush_period plus one publish period;
* start-up is all or nothing: a bad path exits 2 with one line and leaves nothing behind.
"""

from __future__ import annotations

import json
import random
import shutil
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest
from node_support import domain_for, node_env, wait_for_file_growth
from ros_support import require_module, require_rclpy, write_drs_bag, write_split_bag

from drs_ros.node.command_line import node_command

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"
SERVICE_EVENTS = "/drs/drs/_service_event"


def run_tool(*args, env=None, timeout=120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", *args], capture_output=True, text=True, timeout=timeout, env=env
    )


def judge_with_rosbags(bag: Path) -> dict[str, int]:
    """Decode every message with rosbags and compare its serialisation with the recorded bytes;
    returns the count per topic."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore
    from rosbags.typesys.msg import get_types_from_msg

    counts: dict[str, int] = {}
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        store = reader.typestore
        for msgtype, msgdef in {c.msgtype: c.msgdef.data for c in reader.connections}.items():
            if "/srv/" in msgtype:  # rosbags' own name for the type (see the docstring)
                store.register(get_types_from_msg(msgdef, msgtype))
        for conn, _t, raw in reader.messages():
            name = (
                conn.msgtype.replace("/srv/", "/srv/msg/")
                if "/srv/" in conn.msgtype
                else conn.msgtype
            )
            again = bytes(store.serialize_cdr(store.deserialize_cdr(raw, name), name))
            assert again == bytes(raw), f"{conn.topic}: recorded bytes are not the exact CDR"
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
    return counts


def judge_with_mcap_ros2(bag: Path) -> dict[str, int]:
    """Decode every message with mcap_ros2 (service events with rclpy's type support)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rclpy.serialization import deserialize_message
    from std_srvs.srv import SetBool

    counts: dict[str, int] = {}
    factory = DecoderFactory()
    with open(next(bag.glob("*.mcap")), "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if "/srv/" in schema.name:  # a service event (any node's, any namespace)
                event = deserialize_message(message.data, SetBool.Event)
                assert len(event.request) + len(event.response) == 1
            else:
                decoded = factory.decoder_for(channel.message_encoding, schema)(message.data)
                assert decoded is not None
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    return counts


EVERY_TOPIC = {
    "/joint_states",
    "/drs/piston_force",
    "/drs/flap_gap",
    "/drs/piston_acceleration",
    "/drs/joint_reactions",
    "/drs/markers",
    "/diagnostics",
    "/drs/command_events",
    "/parameter_events",
    "/drs/stroke_cmd",
    "/drs/force_cmd",
    "/drs/trajectory_cmd",
    SERVICE_EVENTS,
}


@pytest.mark.parametrize("which", ["example", "node"])
def test_every_message_is_exact_for_independent_readers(which, request):
    require_module("rosbags")
    bag = EXAMPLE if which == "example" else request.getfixturevalue("node_bag")
    by_rosbags = judge_with_rosbags(bag)
    by_mcap = judge_with_mcap_ros2(bag)
    assert by_rosbags == by_mcap
    assert set(by_rosbags) >= EVERY_TOPIC, f"missing topics: {EVERY_TOPIC - set(by_rosbags)}"
    assert all(n > 0 for n in by_rosbags.values())


def test_info_prints_what_ros2_bag_info_prints(node_bag):
    res = run_tool("drs_ros.bag.cli", "info", str(node_bag))
    assert res.returncode == 0, res.stderr
    out = res.stdout
    counts = judge_with_mcap_ros2(node_bag)
    assert "Storage id:        mcap" in out and "ROS Distro:        jazzy" in out
    for topic, n in counts.items():
        if topic != SERVICE_EVENTS:
            assert f"Topic: {topic} | Type: " in out and f" | Count: {n} | " in out
    assert (
        f"Service: /drs/drs | Type: std_srvs/srv/SetBool | Event Count: "
        f"{counts[SERVICE_EVENTS]}" in out
    )
    assert f"Messages:          {sum(counts.values()) - counts[SERVICE_EVENTS]}" in out


def _corrupt(kind: str, src: Path, dst: Path, rng: random.Random) -> Path:
    shutil.copytree(src, dst)
    mcap = next(dst.glob("*.mcap"))
    raw = bytearray(mcap.read_bytes())
    if kind == "truncate_half":
        mcap.write_bytes(raw[: len(raw) // 2])
    elif kind == "truncate_random":
        mcap.write_bytes(raw[: rng.randrange(9, len(raw) - 1)])
    elif kind == "flip_chunk":
        at = len(raw) // 3  # inside the data section
        raw[at] ^= 0xFF
        mcap.write_bytes(raw)
    elif kind == "overwrite_message":
        at = raw.find(b"drs_piston", len(raw) // 2)  # inside a JointState of a later chunk
        raw[at : at + 4] = b"XXXX"
        mcap.write_bytes(raw)
    elif kind == "no_metadata":
        (dst / "metadata.yaml").unlink()
    elif kind == "empty":
        mcap.write_bytes(b"")
    elif kind == "not_mcap":
        mcap.write_bytes(b"%PDF-1.4 not a bag" * 50)
    elif kind == "trailing_bytes":
        mcap.write_bytes(bytes(raw) + b"\x00\x01")
    return dst


CORRUPTIONS = [
    "truncate_half",
    "truncate_random",
    "flip_chunk",
    "overwrite_message",
    "no_metadata",
    "empty",
    "not_mcap",
    "trailing_bytes",
]


@pytest.mark.parametrize("kind", CORRUPTIONS)
def test_check_refuses_every_corruption_with_one_line(kind, tmp_path):
    require_rclpy()
    bag = _corrupt(kind, EXAMPLE, tmp_path / "bag", random.Random(kind))
    res = run_tool("drs_ros.bag.cli", "check", str(bag))
    assert res.returncode == 2, res.stdout[-2000:]
    assert "PASS" not in res.stdout and "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("drs-bag check: error: "), res.stderr


def test_sigkill_then_recover_gives_a_bag_every_reader_reads(tmp_path, request):
    require_rclpy()
    require_module("rosbags")
    flush, publish_hz = 0.2, 250.0
    env = node_env(tmp_path, domain_for(request.node.nodeid))
    proc = subprocess.Popen(
        node_command(
            {"bag_path": tmp_path / "bag", "flush_period": flush, "publish_rate_hz": publish_hz}
        ),
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        # well past start-up (which takes seconds on a loaded machine), with flushes behind it
        assert wait_for_file_growth(tmp_path / "bag" / "bag_0.mcap", timeout=60)
        time.sleep(2.0)
    finally:
        kill_ns = time.time_ns()
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    assert not (tmp_path / "bag" / "metadata.yaml").exists()
    res = run_tool("drs_ros.bag.cli", "check", str(tmp_path / "bag"))
    assert res.returncode == 2 and "drs-bag recover" in res.stderr
    res = run_tool(
        "drs_ros.bag.cli", "recover", str(tmp_path / "bag"), "-o", str(tmp_path / "fixed"), "--json"
    )
    assert res.returncode == 3, res.stderr  # damaged source, readable part kept
    import json

    report = json.loads(res.stdout)
    # the lost tail: from the last recovered message to the kill, at most one flush period and
    # one publish period (plus the scheduling slack of a loaded machine)
    lost_s = (kill_ns - report["last_log_time_ns"]) * 1e-9
    assert 0.0 <= lost_s <= flush + 1.0 / publish_hz + 0.25, lost_s
    counts = judge_with_rosbags(tmp_path / "fixed")
    assert counts == judge_with_mcap_ros2(tmp_path / "fixed")
    assert counts["/joint_states"] > 100
    assert run_tool("drs_ros.bag.cli", "check", str(tmp_path / "fixed")).returncode == 0


@pytest.mark.parametrize(
    "case", ["existing_rrd", "unwritable_rrd", "bag_is_a_file", "existing_bag"]
)
def test_start_up_is_all_or_nothing(case, tmp_path, request):
    require_rclpy()
    bag, rrd = tmp_path / "bag", tmp_path / "run.rrd"
    before: set[Path] = set()
    if case == "existing_rrd":
        rrd.write_bytes(b"an earlier recording")
    elif case == "unwritable_rrd":
        rrd = Path("/proc/drs-test.rrd")
    elif case == "bag_is_a_file":
        bag.write_bytes(b"x")
    else:
        bag.mkdir()
        (bag / "bag_0.mcap").write_bytes(b"an earlier run")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    res = subprocess.run(
        node_command({"bag_path": bag, "rrd_path": rrd}),
        env=node_env(tmp_path / "log", domain_for(request.node.nodeid)),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 2, res.stderr
    errors = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(errors) == 1 and errors[0].startswith("drs-node: refused to start: "), res.stderr
    assert "Traceback" not in res.stderr and "overwrite=True" not in res.stderr
    after = {
        p: p.read_bytes()
        for p in tmp_path.rglob("*")
        if p.is_file() and "log" not in p.relative_to(tmp_path).parts
    }
    assert after == before  # nothing created, nothing changed


def test_transport_padding_is_told_apart_from_leaked_bytes(tmp_path):
    """Up to 3 zero bytes after the exact CDR are Fast DDS's padding (it pads a message that
    crosses processes to a multiple of 4): the node strips them, the checker accepts and counts
    them. Anything else after the message is refused."""
    require_rclpy()
    from message_support import serialize
    from std_srvs.srv import SetBool

    from drs_ros.bag.read.files import BagReadError
    from drs_ros.bag.read.reader import scan
    from drs_ros.recording import cdr, cdr_received
    from drs_ros.recording.mcap_recorder import McapRecorder

    event = SetBool.Event()
    event.response = [SetBool.Response(success=True, message="opened")]
    exact = serialize(event)
    assert len(exact) % 4 != 0  # a string at the end: the transport would pad it
    padded = exact + bytes(-len(exact) % 4)
    assert cdr_received.exact_bytes(padded, SetBool.Event) == exact
    with pytest.raises(cdr.CdrError, match="plus at most 3 zero bytes"):
        cdr_received.exact_bytes(exact + b"\x01", SetBool.Event)
    for name, data, ok in (
        ("padded", padded, True),
        ("leaked", exact + b"\x7f\x00", False),
        ("long", exact + bytes(4), False),
    ):
        with McapRecorder(tmp_path / name, flush_thread=False) as rec:
            rec.register_topic(SERVICE_EVENTS, SetBool.Event, 10)
            rec.write(SERVICE_EVENTS, data, 1)
        if ok:
            result = scan(tmp_path / name)
            assert result.complete and any("padding" in n for n in result.notes)
        else:
            with pytest.raises(BagReadError, match=r"bytes where its CDR serialisation is"):
                scan(tmp_path / name)


# ---- metadata.yaml: malformed is one line and exit status 2, for every verb ----------------------
def _example_metadata() -> dict:
    import yaml

    return yaml.safe_load((EXAMPLE / "metadata.yaml").read_text())


def _malformed(kind: str):
    """The text (or bytes) of a malformed metadata.yaml, and words the error must hold."""
    import yaml

    meta = _example_metadata()
    info = meta["rosbag2_bagfile_information"]
    if kind == "not_yaml":
        return "rosbag2_bagfile_information: [unclosed\n  - : :\n", "not YAML"
    if kind == "not_utf8":
        return b"\xff\xfe\x00rosbag2", "cannot be read"
    if kind == "empty":
        return "", "not a mapping"
    if kind == "a_list":
        return "- 1\n- 2\n", "not a mapping"
    if kind == "no_key":
        return yaml.safe_dump({"other": info}), "no key 'rosbag2_bagfile_information'"
    if kind == "info_not_mapping":
        return "rosbag2_bagfile_information: 3\n", "must be a mapping"
    if kind == "count_not_int":
        info["topics_with_message_count"][1]["message_count"] = "many"
        words = "topics_with_message_count[1].message_count must be an integer >= 0, got 'many'"
    elif kind == "negative_total":
        info["message_count"] = -5
        words = "message_count must be an integer >= 0, got -5"
    elif kind == "no_topic_metadata":
        del info["topics_with_message_count"][0]["topic_metadata"]
        words = "topics_with_message_count[0].topic_metadata is missing"
    elif kind == "files_not_a_list":
        info["relative_file_paths"] = "example_0.mcap"
        words = "relative_file_paths must be a non-empty list"
    elif kind == "file_outside":
        info["relative_file_paths"] = ["/etc/passwd"]
        words = "must name a file inside the bag directory"
    elif kind == "no_starting_time":
        del info["starting_time"]
        words = "starting_time is missing"
    else:
        raise AssertionError(kind)
    return yaml.safe_dump(meta, sort_keys=False), words


MALFORMED = [
    "not_yaml",
    "not_utf8",
    "empty",
    "a_list",
    "no_key",
    "info_not_mapping",
    "count_not_int",
    "negative_total",
    "no_topic_metadata",
    "files_not_a_list",
    "file_outside",
    "no_starting_time",
]
VERBS = ["info", "check", "recover", "resimulate", "play"]


def _bag_with_metadata(tmp_path: Path, kind: str) -> tuple[Path, str]:
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "example_0.mcap").symlink_to(EXAMPLE / "example_0.mcap")
    text, words = _malformed(kind)
    meta = bag / "metadata.yaml"
    meta.write_bytes(text) if isinstance(text, bytes) else meta.write_text(text)
    return bag, words


@pytest.mark.parametrize("kind", MALFORMED)
def test_a_malformed_metadata_yaml_is_one_line_and_status_2_for_every_verb(kind, tmp_path, capsys):
    """Every verb, in process (drs_ros.bag.cli.main): exit 2, one stderr line naming the file and
    what is wrong, nothing written (recover's output is not created)."""
    require_rclpy()
    from drs_ros.bag.cli import main

    bag, words = _bag_with_metadata(tmp_path, kind)
    for verb in VERBS:
        extra = ["-o", str(tmp_path / "out")] if verb == "recover" else []
        status = main([verb, str(bag), *extra])
        err = capsys.readouterr().err
        lines = [line for line in err.splitlines() if line.strip()]
        assert status == 2, (verb, err)
        assert len(lines) == 1 and lines[0].startswith(f"drs-bag {verb}: error: "), (verb, err)
        assert str(bag / "metadata.yaml") in lines[0] and words in lines[0], (verb, lines[0])
        assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("kind", ["not_yaml", "count_not_int"])
def test_a_malformed_metadata_yaml_gives_no_traceback(kind, tmp_path):
    require_rclpy()
    bag, words = _bag_with_metadata(tmp_path, kind)
    res = run_tool("drs_ros.bag.cli", "check", str(bag))
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], res.stderr


# ---- a failing callback is the caller's, not the bag's -------------------------------------------
def test_a_failing_callback_is_not_a_verdict_on_the_bag(tmp_path, params):
    """A callback raising on the 50th message: the scan raises MessageCallbackError (caused by
    the callback's exception) with or without ``recover``: never a BagReadError, never a scan
    ended as if the file were truncated there."""
    require_rclpy()
    from drs_ros.bag.read.files import BagReadError
    from drs_ros.bag.read.reader import scan

    rec, *_ = write_drs_bag(tmp_path / "bag", params, n=100, recorder_kwargs={"flush_messages": 30})
    bug = ValueError("the caller's own bug")
    seen: list = []

    def callback(message) -> None:
        seen.append(message)
        if len(seen) == 50:
            raise bug

    for recover in (False, True):
        seen.clear()
        try:
            result = scan(rec.bag_dir, callback, recover=recover)
        except Exception as exc:  # noqa: BLE001 - what it is is the test
            raised = exc
        else:
            pytest.fail(
                f"recover={recover}: the callback's error ended the scan as damage to "
                f"the file: {result.reason!r}, {result.message_count} kept"
            )
        assert not isinstance(raised, BagReadError), f"reported as the bag's fault: {raised}"
        assert type(raised).__name__ == "MessageCallbackError" and raised.__cause__ is bug
        assert (raised.topic, raised.offset) == (seen[-1].topic, seen[-1].offset)
        assert "ValueError: the caller's own bug" in str(raised) and "\n" not in str(raised)
    assert scan(rec.bag_dir).complete  # the file itself is intact


def _bag_of_an_uninstalled_type(bag: Path) -> None:
    """/joint_states recorded as a type this machine does not have: intact, undecodable here."""
    from drs_ros.recording.mcap_recorder import McapRecorder

    with McapRecorder(bag, flush_thread=False) as rec:
        rec.register_recorded_topic(
            "/joint_states", "drs_test_msgs/msg/Unknown", b"float64 x", "ros2msg", [], ""
        )
        for k in range(20):
            rec.write(
                "/joint_states",
                b"\x00\x01\x00\x00" + struct.pack("<d", k),
                1_700_000_000_000_000_000 + k * 1_000_000,
            )


def test_check_reports_its_own_failure_apart_from_corruption(tmp_path):
    """check must decode /joint_states; a type it cannot decode is its failure (exit 4, one
    line), not the file's (exit 2) nor a truncation (--recover: exit 3). recover copies the
    whole bag (it decodes nothing)."""
    require_rclpy()
    bag = tmp_path / "bag"
    _bag_of_an_uninstalled_type(bag)
    for extra in ([], ["--recover"]):
        res = run_tool("drs_ros.bag.cli", "check", str(bag), *extra)
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 4, (extra, res.stdout[-1000:], res.stderr)
        assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
        assert lines[0].startswith("drs-bag check: internal error (not a verdict on the bag): ")
        assert "/joint_states" in lines[0] and "passed every check of the file" in lines[0]
    res = run_tool("drs_ros.bag.cli", "recover", str(bag), "-o", str(tmp_path / "copy"), "--json")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["per_topic"] == {"/joint_states": 20}


def test_recover_that_cannot_write_its_output_leaves_nothing(tmp_path):
    """The output cannot grow past 64 KiB (RLIMIT_FSIZE, a real EFBIG from the kernel): the copy
    fails inside the scan's callback. recover must say it could not write OUT (exit 2, one
    line), not that the source is damaged, and leave no truncated OUT behind."""
    require_rclpy()
    import resource

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (64 * 1024, 64 * 1024))

    out = tmp_path / "out"
    res = subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.cli", "recover", str(EXAMPLE), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=limit,
    )
    assert res.returncode == 2, (res.stdout[-1000:], res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert f"cannot write the recovered bag {str(out)!r}" in lines[0], lines[0]
    assert not out.exists()


# ---- split bags ---------------------------------------------------------------------------------
def test_resolve_finds_every_file_of_a_split_bag_in_order(tmp_path):
    from drs_ros.bag.read.files import BagReadError, resolve

    for k in (10, 0, 2, 1, 11):
        (tmp_path / f"run_{k}.mcap").write_bytes(b"")
    bag = resolve(tmp_path, require_metadata=False)
    assert [f.name for f in bag.files] == [f"run_{k}.mcap" for k in (0, 1, 2, 10, 11)]
    assert bag.bag_dir == tmp_path and bag.metadata is None
    with pytest.raises(BagReadError, match="run_0.mcap, run_1.mcap, .*drs-bag recover"):
        resolve(tmp_path)


def test_check_and_info_read_every_file_of_awrite_split_bag(tmp_path, params, capsys):
    require_rclpy()
    from drs_ros.bag.check import command as check
    from drs_ros.bag.cli import main

    bag, _first = write_split_bag(tmp_path, params, killed=False)
    assert check.main([str(bag), "--json"]) == 0, capsys.readouterr().err
    report = json.loads(capsys.readouterr().out)
    assert report["messages"] == {
        "/joint_states": 240,
        "/drs/flap_gap": 240,
        "/drs/piston_force": 240,
    }
    assert main(["info", str(bag), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["files"] == ["split_0.mcap", "split_1.mcap"]
    # metadata.yaml's counts are checked against the sum over the files
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace("message_count: 720", "message_count: 719"))
    assert check.main([str(bag)]) == 2
    assert "counts 719 messages, its 2 files hold 720" in capsys.readouterr().err


def test_recover_keeps_every_file_of_a_killedwrite_split_bag(tmp_path, params):
    """split_0.mcap complete, split_1.mcap cut (SIGKILL): the recovered bag holds every message
    of the first file and the readable part of the second, in order, byte for byte; check
    passes on it and rosbags reads it."""
    require_rclpy()
    require_module("rosbags")
    from drs_ros.bag.read.reader import scan

    bag, first = write_split_bag(tmp_path, params, killed=True)
    res = run_tool("drs_ros.bag.cli", "check", str(bag), "--recover", "--json")
    assert res.returncode == 3, res.stderr
    assert sum(json.loads(res.stdout)["messages"].values()) > first  # both files were read
    out = tmp_path / "fixed"
    res = run_tool("drs_ros.bag.cli", "recover", str(bag), "-o", str(out), "--json")
    assert res.returncode == 3, res.stderr
    report = json.loads(res.stdout)
    files = report["files"]
    assert [Path(f["file"]).name for f in files] == ["split_0.mcap", "split_1.mcap"]
    assert files[0]["complete"] and files[0]["messages"] == first and files[0]["bytes_lost"] == 0
    assert not files[1]["complete"] and 0 < files[1]["messages"] < first
    assert files[1]["bytes_lost"] > 0 and "split_1.mcap" in report["reason"]
    assert report["messages"] == first + files[1]["messages"]
    text = run_tool("drs_ros.bag.cli", "recover", str(bag), "-o", str(tmp_path / "again"))
    assert "split_0.mcap: complete" in text.stdout and "split_1.mcap: " in text.stdout

    # what was written is what the two files hold, in order (times, sequences, bytes)
    source: list = []
    scan(bag, source.append, recover=True)
    copied: list = []
    assert scan(out, copied.append).complete
    key = [(m.topic, m.log_time, m.publish_time, m.sequence, m.data) for m in source]
    assert [(m.topic, m.log_time, m.publish_time, m.sequence, m.data) for m in copied] == key
    assert len(key) == report["messages"]
    assert run_tool("drs_ros.bag.cli", "check", str(out)).returncode == 0
    assert judge_with_rosbags(out) == report["per_topic"]
