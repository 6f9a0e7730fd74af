"""``drs-bag play`` over real DDS (each test on its own domain) and its offline parts.

The player runs as a process (``python -m drs_ros.bag.replay.play``); the subscribers are raw rclpy
subscriptions in the test, so what arrives is compared byte for byte with what ``mcap``'s own
reader finds in the bag. Timing is judged by ratios with wide margins, never by wall-clock limits.
"""

from __future__ import annotations

import shutil
import signal
import struct
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path
from types import SimpleNamespace

import pytest
from node_support import domain_for, node_env, spin_for, spin_until
from ros_support import require_module, require_rclpy

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"
#: Start options: discovery on loopback took 0.03-3.3 s here, so rather than a longer --delay the
#: player waits until every topic it plays has matched a subscriber.
START = ("--delay", "0.1", "--wait-for-subscribers")


#: The history both sides keep where a test needs every message: keep-last this deep on the
#: player's writers (``no_loss``) and on the test's readers (:class:`RawSubscriber`), more than
#: any topic of a bag these tests play holds (the example: 1,679 on a topic), so that neither side
#: ever replaces a sample the other has not taken, however long the test process falls behind.
LOSSLESS_DEPTH = 4096


def no_loss(tmp_path, bag: Path = EXAMPLE) -> tuple[str, ...]:
    """``--qos-profile-overrides-path`` offering keep-last :data:`LOSSLESS_DEPTH` on every topic
    of ``bag``, and ``--wait-for-all-acked 10000``.

    rosbag2 offers a recorded profile with keep-last 10. A reliable Fast DDS writer drops its
    oldest sample once that many are unacknowledged, and a keep-last reader drops its oldest
    unread one, so a test process that falls behind loses messages: with keep-last 10, seen once
    in 8 benchmark runs at rate 1; with keep-last 1000, once in a full test run while both cores
    were busy (69 of 1,679 on a topic: the example plays ~2,450 messages a second into the test's
    Python executor). A test process stopped for 2.5 s during the play loses none now.
    """
    import yaml

    types, messages = recorded(bag)
    most = max(len(v) for v in messages.values())
    assert most <= LOSSLESS_DEPTH, f"{bag} has {most} messages on a topic: raise LOSSLESS_DEPTH"
    path = tmp_path / "qos_overrides.yaml"
    path.write_text(yaml.safe_dump({topic: {"depth": LOSSLESS_DEPTH} for topic in types}))
    # and the player waits up to 10 s (not its default 1 s) for every message to be
    # acknowledged before it exits: one message of 1679 was missing once in a full test run
    return ("--qos-profile-overrides-path", str(path), "--wait-for-all-acked", "10000")


FLOAT64 = "std_msgs/msg/Float64"
QOS_YAML = """- history: keep_last
  depth: 10
  reliability: reliable
  durability: volatile
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false"""


# ---- the bag, read independently ----------------------------------------------------------------
def recorded(bag: Path) -> tuple[dict[str, str], dict[str, list[tuple[int, bytes]]]]:
    """``(types, messages)``: topic -> ``pkg/msg/Type`` and topic -> [(log_time, bytes)] in
    log-time order, read with ``mcap.reader.make_reader``."""
    mcap_reader = require_module("mcap.reader")
    path = next(bag.glob("*.mcap")) if bag.is_dir() else bag
    types: dict[str, str] = {}
    messages: dict[str, list[tuple[int, bytes]]] = {}
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f)
        summary = reader.get_summary()
        for ch in summary.channels.values():
            types[ch.topic] = summary.schemas[ch.schema_id].name
            messages[ch.topic] = []
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            messages[channel.topic].append((message.log_time, bytes(message.data)))
    return types, messages


def as_received(messages: list[tuple[int, bytes]]) -> list[bytes]:
    """The recorded bytes as a subscriber in another process receives them.

    Fast DDS carries a serialised payload in whole 4-byte words: a message whose CDR length is
    not a multiple of 4 arrives with zero bytes appended up to the next multiple (measured here
    for a raw publish and for a message object alike: a 650-byte DiagnosticArray arrives as 652
    bytes, ending in two zeros). Nothing else may differ.
    """
    return [data + b"\0" * (-len(data) % 4) for _t, data in messages]


def write_bag(path: Path, channels: list[tuple[str, str]], messages: list[tuple[str, int, bytes]]):
    """A rosbag2-style MCAP file: ``channels`` [(topic, type)], ``messages`` [(topic, t, data)]."""
    writer_mod = require_module("mcap.writer")
    with open(path, "wb") as f:
        writer = writer_mod.Writer(f)
        writer.start(profile="ros2", library="test_bag_play")
        ids = {}
        for topic, type_name in channels:
            schema = writer.register_schema(type_name, "ros2msg", b"float64 data")
            ids[topic] = writer.register_channel(
                topic, "cdr", schema, {"offered_qos_profiles": QOS_YAML}
            )
        for topic, t_ns, data in messages:
            writer.add_message(ids[topic], log_time=t_ns, data=data, publish_time=t_ns)
        writer.finish()


def float64_cdr(value: float) -> bytes:
    """CDR of std_msgs/Float64 (little-endian encapsulation header, then the double)."""
    return b"\x00\x01\x00\x00" + struct.pack("<d", value)


# ---- subscriber and player ----------------------------------------------------------------------
def _from_a_live_node(data: bytes) -> bool:
    """A ParameterEvent that the player node or this test's node published about itself (every
    rclpy node announces its parameters on /parameter_events when it starts; whether the test
    hears it depends on how fast discovery is), not one played from the bag."""
    from rcl_interfaces.msg import ParameterEvent
    from rclpy.serialization import deserialize_message

    return deserialize_message(data, ParameterEvent).node in ("/rosbag2_player", "/bag_play_test")


class RawSubscriber:
    """One node with a raw subscription per topic: what arrived, and when (monotonic [s])."""

    def __init__(self, context, types: dict[str, str], node_name="bag_play_test", **node_kw):
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        from drs_ros.recording.msgdefs import message_class

        self.node = Node(node_name, context=context, **node_kw)
        self.received: dict[str, list[bytes]] = {t: [] for t in types}
        self.arrival: dict[str, list[float]] = {t: [] for t in types}
        qos = QoSProfile(depth=LOSSLESS_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
        for topic, type_name in types.items():
            self.node.create_subscription(
                message_class(type_name), topic, self._callback(topic), qos, raw=True
            )
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)

    def _callback(self, topic):
        def store(data: bytes) -> None:
            if topic == "/parameter_events" and _from_a_live_node(data):
                return  # the player's own parameters (as rosbag2_player's), not the bag's
            self.arrival[topic].append(time.monotonic())
            self.received[topic].append(bytes(data))

        return store

    def count(self) -> int:
        return sum(len(v) for v in self.received.values())

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


def start_play(tmp_path, request, *args: str) -> subprocess.Popen:
    require_rclpy()
    return subprocess.Popen(
        [sys.executable, "-m", "drs_ros.bag.replay.play", *args],
        env=node_env(tmp_path, domain_for(request.node.nodeid)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def play_example(tmp_path, request, *options: str) -> subprocess.Popen:
    """``drs-bag play`` of the example bag from its start, losing nothing, with ``options``."""
    return start_play(tmp_path, request, str(EXAMPLE), *START, *no_loss(tmp_path), *options)


def receive_until_exit(sub: RawSubscriber, proc: subprocess.Popen, expected: int, timeout=60.0):
    """Spin until ``expected`` messages arrived or the player ended; then until the messages
    DDS holds for this process are taken (at most 30 s: a test process that fell behind drains
    them at a few thousand a second)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and sub.count() < expected:
        sub.executor.spin_once(timeout_sec=0.01)
        if proc.poll() is not None:
            spin_until(sub.executor, lambda: sub.count() >= expected, timeout=30.0)
            break
    out, err = proc.communicate(timeout=30)
    return out, err


def assert_clean_exit(proc, err: str) -> None:
    assert proc.returncode == 0, err
    assert "Traceback" not in err, err


# ---- over DDS -----------------------------------------------------------------------------------
def test_every_message_arrives_byte_identical_and_in_order(ros_context, tmp_path, request):
    types, messages = recorded(EXAMPLE)
    expected = {t: as_received(msgs) for t, msgs in messages.items()}
    total = sum(len(v) for v in expected.values())
    assert total > 1000 and len([t for t in expected if expected[t]]) >= 5  # a real bag
    sub = RawSubscriber(ros_context, types)
    try:
        proc = play_example(tmp_path, request)
        _out, err = receive_until_exit(sub, proc, total)
        assert_clean_exit(proc, err)
        for topic in types:
            got = sub.received[topic]
            assert len(got) == len(expected[topic]), topic
            assert got == expected[topic], f"{topic}: bytes or order differ"
        # the recorded timing: arrival time against log time has slope ~1 (rate 1)
        t_log, t_arr = zip(
            *[
                (t, a)
                for (t, _), a in zip(
                    messages["/joint_states"], sub.arrival["/joint_states"], strict=True
                )
            ],
            strict=True,
        )
        assert 0.75 < slope(t_log, t_arr) < 1.35
    finally:
        sub.close()


def slope(t_log_ns, t_wall_s) -> float:
    """Least-squares slope of wall time [s] against bag time [s]."""
    import numpy as np

    x = (np.asarray(t_log_ns, dtype=np.int64) - t_log_ns[0]) / 1e9
    return float(np.polyfit(x, np.asarray(t_wall_s) - t_wall_s[0], 1)[0])


def test_topics_plays_only_the_chosen_topics(ros_context, tmp_path, request):
    types, messages = recorded(EXAMPLE)
    chosen = ["/drs/flap_gap", "/drs/stroke_cmd"]
    sub = RawSubscriber(ros_context, types)
    try:
        proc = play_example(tmp_path, request, "--topics", *chosen)
        expected = sum(len(messages[t]) for t in chosen)
        _out, err = receive_until_exit(sub, proc, expected)
        spin_for(sub.executor, 0.3)  # anything else would have arrived with them
        assert_clean_exit(proc, err)
        for topic in types:
            want = as_received(messages[topic]) if topic in chosen else []
            assert sub.received[topic] == want, topic
    finally:
        sub.close()


def test_a_sqlite3_bag_plays_the_same_bytes_in_the_same_order(ros_context, tmp_path, request):
    """rosbag2's sqlite3 storage (the example copied into a .db3 by rosbags' writer) plays
    through rosbags: every message of the chosen topics, byte-identical, in log-time order."""
    from ros_support import mcap_to_db3

    types, messages = recorded(EXAMPLE)
    db3 = mcap_to_db3(EXAMPLE, tmp_path / "example_db3")
    chosen = ["/joint_states", "/drs/flap_gap", "/drs/stroke_cmd"]
    sub = RawSubscriber(ros_context, {t: types[t] for t in chosen})
    try:
        proc = start_play(
            tmp_path,
            request,
            str(db3),
            *START,
            *no_loss(tmp_path),
            "--rate",
            "4",
            "--topics",
            *chosen,
        )
        expected = sum(len(messages[t]) for t in chosen)
        _out, err = receive_until_exit(sub, proc, expected)
        assert_clean_exit(proc, err)
        for topic in chosen:
            assert sub.received[topic] == as_received(messages[topic]), topic
    finally:
        sub.close()


def test_rate_2_plays_twice_as_fast(ros_context, tmp_path, request):
    types, messages = recorded(EXAMPLE)
    topic = "/joint_states"
    sub = RawSubscriber(ros_context, {topic: types[topic]})
    try:
        proc = play_example(tmp_path, request, "--rate", "2", "--topics", topic)
        _out, err = receive_until_exit(sub, proc, len(messages[topic]))
        assert_clean_exit(proc, err)
        assert sub.received[topic] == as_received(messages[topic])
        t_log = [t for t, _d in messages[topic]]
        # wall time per bag second: 0.5 at rate 2 (1 at rate 1), with wide margins
        assert 0.35 < slope(t_log, sub.arrival[topic]) < 0.7
    finally:
        sub.close()


def test_loop_plays_everything_again_until_sigint(ros_context, tmp_path, request):
    types, messages = recorded(EXAMPLE)
    chosen = {t: types[t] for t in ("/drs/stroke_cmd", "/drs/force_cmd", "/drs/flap_gap")}
    once = {t: as_received(messages[t]) for t in chosen}
    sub = RawSubscriber(ros_context, chosen)
    try:
        proc = play_example(tmp_path, request, "--loop", "--topics", *chosen)
        twice = 2 * sum(len(v) for v in once.values())
        assert spin_until(sub.executor, lambda: sub.count() >= twice, timeout=60.0), sub.count()
        assert proc.poll() is None  # still looping
        proc.send_signal(signal.SIGINT)
        _out, err = proc.communicate(timeout=20)
        assert_clean_exit(proc, err)
        for topic, data in once.items():
            assert sub.received[topic][: 2 * len(data)] == data + data, topic
    finally:
        sub.close()


def test_clock_drives_a_sim_time_node(ros_context, tmp_path, request):
    from rclpy.parameter import Parameter

    types, messages = recorded(EXAMPLE)
    topic = "/drs/stroke_cmd"
    first = min(m[0][0] for m in messages.values() if m)  # the clock starts at the bag's start
    last = messages[topic][-1][0]  # and play ends with the last message played
    assert last - first > 1_000_000_000
    sub = RawSubscriber(
        ros_context,
        {topic: types[topic]},
        node_name="sim_time_node",
        parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)],
    )
    try:
        assert sub.node.get_clock().now().nanoseconds == 0  # no /clock yet
        proc = play_example(tmp_path, request, "--clock", "50", "--topics", topic)
        seen: list[tuple[float, int]] = []
        while proc.poll() is None:
            sub.executor.spin_once(timeout_sec=0.01)
            now = sub.node.get_clock().now().nanoseconds
            if now and (not seen or now != seen[-1][1]):
                seen.append((time.monotonic(), now))
        _out, err = proc.communicate(timeout=20)
        assert_clean_exit(proc, err)
        sim = [ns for _w, ns in seen]
        assert len(sim) > 20
        assert sim == sorted(sim)
        assert all(first <= ns <= last + 200_000_000 for ns in sim), (first, sim[0], sim[-1])
        assert sim[-1] - sim[0] > 0.7 * (last - first)  # it followed the bag to its end
        # the sim-time node's clock moves at the bag's pace (rate 1): ~1 bag s per wall s
        moving = [(w, ns) for w, ns in seen if ns > first]
        assert 0.75 < 1.0 / slope([ns for _w, ns in moving], [w for w, _ns in moving]) < 1.35
        assert len(sub.received[topic]) == len(messages[topic])
    finally:
        sub.close()


@pytest.mark.parametrize("delay_s", [0.0, 0.2])
def test_the_clock_holds_the_bags_start_until_play_begins_and_never_goes_back(
    ros_context, monkeypatch, delay_s
):
    """A stall of 0.3 s between the play's start and its first /clock (a busy machine; it made
    ``test_clock_drives_a_sim_time_node`` see /clock 0.34 s on, then the start again): every
    /clock the player publishes is at or after the one before, and the first is the bag's start
    (the reference: the bag's own start time), held until play begins."""
    import rclpy

    from drs_ros.bag.replay.play import player as player_module
    from drs_ros.bag.replay.play.index import index_bag
    from drs_ros.bag.replay.play.options import PlayOptions
    from drs_ros.stop_request import StopRequest

    index = index_bag(str(EXAMPLE))
    topic = "/drs/stroke_cmd"
    options = PlayOptions(bag=str(EXAMPLE), topics=(topic,), clock_hz=50.0, delay_s=delay_s)
    node = rclpy.create_node("clock_player", context=ros_context)
    try:
        player = player_module.Player(node, index, options, StopRequest())
        clocks, first_message = [], []
        publish_clock = player._publish_clock
        player._publish_clock = lambda ns: clocks.append(ns) or publish_clock(ns)
        play_pub = player.publishers[topic]
        publish = play_pub.publish
        play_pub.publish = lambda data: first_message.append(len(clocks)) or publish(data)
        real, calls = time.monotonic, []

        def monotonic() -> float:  # off its core for 0.3 s once play has read the time twice
            calls.append(1)  # (the clock's first tick, then the play's start)
            return real() + (0.3 if len(calls) > 2 else 0.0)

        clock = SimpleNamespace(monotonic=monotonic, sleep=time.sleep)
        monkeypatch.setattr(player_module, "time", clock)
        assert player.play()
    finally:
        node.destroy_node()
    assert len(clocks) > 20
    assert clocks == sorted(clocks)
    assert clocks[0] == index.start_ns  # held there until play began, not 0.3 s on
    assert first_message  # it played


def test_sigint_mid_play_stops_cleanly(ros_context, tmp_path, request):
    types, messages = recorded(EXAMPLE)
    topic = "/joint_states"
    sub = RawSubscriber(ros_context, {topic: types[topic]})
    try:
        proc = play_example(tmp_path, request, "--topics", topic, "--rate", "0.5")
        assert spin_until(sub.executor, lambda: sub.count() >= 100, timeout=30.0)
        proc.send_signal(signal.SIGINT)
        _out, err = proc.communicate(timeout=20)
        assert_clean_exit(proc, err)
        got = sub.received[topic]
        recorded_bytes = as_received(messages[topic])
        assert 100 <= len(got) < len(recorded_bytes)  # stopped part way, in order
        assert got == recorded_bytes[: len(got)]
    finally:
        sub.close()


def test_a_topic_of_an_uninstalled_type_is_skipped_with_one_warning(ros_context, tmp_path, request):
    """A bag written by another tool: a Float64 topic, a service event topic (``*_Event`` types
    live in ``pkg.srv``) and a topic whose package is not installed."""
    from rclpy.serialization import serialize_message
    from std_srvs.srv import SetBool

    t0 = 1_700_000_000_000_000_000
    bag = tmp_path / "mixed.mcap"
    known = [float64_cdr(0.5 * k) for k in range(20)]
    events = []
    for k in range(5):
        event = SetBool.Event()
        event.info.event_type = k % 2  # REQUEST_SENT, REQUEST_RECEIVED
        event.info.sequence_number = k
        event.request = [SetBool.Request(data=bool(k % 2))]
        events.append(serialize_message(event))
    event_topic, event_type = "/drs/drs/_service_event", "std_srvs/srv/SetBool_Event"
    msgs = []
    for k, data in enumerate(known):
        msgs.append(("/known", t0 + k * 10_000_000, data))
        msgs.append(("/unknown", t0 + k * 10_000_000 + 1, float64_cdr(-1.0)))
    msgs += [(event_topic, t0 + k * 30_000_000 + 2, data) for k, data in enumerate(events)]
    msgs.sort(key=lambda m: m[1])
    channels = [
        ("/known", FLOAT64),
        ("/unknown", "no_such_pkg/msg/Nothing"),
        (event_topic, event_type),
    ]
    write_bag(bag, channels, msgs)
    sub = RawSubscriber(ros_context, {"/known": FLOAT64, event_topic: event_type})
    try:
        proc = start_play(tmp_path, request, str(bag), *START, *no_loss(tmp_path, bag))
        _out, err = receive_until_exit(sub, proc, len(known) + len(events))
        assert_clean_exit(proc, err)
        assert sub.received["/known"] == known
        assert sub.received[event_topic] == as_received([(0, e) for e in events])
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1, err
        assert "warning" in lines[0] and "/unknown" in lines[0]
        assert "no_such_pkg/msg/Nothing" in lines[0]
    finally:
        sub.close()


def test_remap_publishes_on_the_new_name(ros_context, tmp_path, request):
    types, messages = recorded(EXAMPLE)
    sub = RawSubscriber(ros_context, {"/replay/gap": types["/drs/flap_gap"]})
    try:
        remap = ("--remap", "/drs/flap_gap:=/replay/gap")
        proc = play_example(tmp_path, request, "--rate", "2", "--topics", "/drs/flap_gap", *remap)
        _out, err = receive_until_exit(sub, proc, len(messages["/drs/flap_gap"]))
        assert_clean_exit(proc, err)
        assert sub.received["/replay/gap"] == as_received(messages["/drs/flap_gap"])
    finally:
        sub.close()


def test_start_offset_plays_from_that_time_on(ros_context, tmp_path, request):
    types, messages = recorded(EXAMPLE)
    topic = "/drs/flap_gap"
    start = min(m[0][0] for m in messages.values() if m)
    cut = start + 2_000_000_000
    want = [(t, d) for t, d in messages[topic] if t >= cut]
    assert 0 < len(want) < len(messages[topic])
    sub = RawSubscriber(ros_context, {topic: types[topic]})
    try:
        proc = play_example(tmp_path, request, "--topics", topic, "--start-offset", "2")
        _out, err = receive_until_exit(sub, proc, len(want))
        spin_for(sub.executor, 0.3)
        assert_clean_exit(proc, err)
        assert sub.received[topic] == as_received(want)
    finally:
        sub.close()


def test_progress_line_on_a_terminal_only(tmp_path, request):
    """stderr a terminal: a progress line (bag time, %, rate) that reaches 100 %; a pipe: none."""
    import os
    import pty

    require_rclpy()
    args = [
        sys.executable,
        "-m",
        "drs_ros.bag.replay.play",
        str(EXAMPLE),
        "--rate",
        "4",
        "--topics",
        "/drs/stroke_cmd",
    ]
    env = node_env(tmp_path, domain_for(request.node.nodeid))
    master, slave = pty.openpty()
    try:
        proc = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=slave)
        os.close(slave)
        chunks = []
        while True:
            try:
                block = os.read(master, 4096)
            except OSError:  # EIO: the terminal's other side closed
                break
            if not block:
                break
            chunks.append(block)
        proc.wait(timeout=30)
    finally:
        os.close(master)
    text = b"".join(chunks).decode()
    assert proc.returncode == 0, text
    lines = [part for part in text.replace("\n", "\r").split("\r") if "bag time" in part]
    assert len(lines) >= 2, text
    assert "100.0 %" in lines[-1] and "rate 4" in lines[-1]
    res = subprocess.run(args, env=env, capture_output=True, text=True, timeout=60)
    assert res.returncode == 0 and res.stderr == "", res.stderr


def test_a_corrupt_chunk_found_while_playing_exits_2_in_one_line(ros_context, tmp_path, request):
    _types, messages = recorded(EXAMPLE)
    data = bytearray((next(EXAMPLE.glob("*.mcap"))).read_bytes())
    mcap_reader = require_module("mcap.reader")
    with open(next(EXAMPLE.glob("*.mcap")), "rb") as f:
        chunks = mcap_reader.make_reader(f).get_summary().chunk_indexes
    last = max(chunks, key=lambda c: c.message_start_time)
    middle = last.chunk_start_offset + last.chunk_length // 2
    data[middle : middle + 16] = bytes(b ^ 0xFF for b in data[middle : middle + 16])
    bad = tmp_path / "corrupt.mcap"
    bad.write_bytes(bytes(data))
    played = ("/joint_states", "/drs/piston_force")
    before = sum(1 for topic in played for t, _ in messages[topic] if t < last.message_start_time)
    sub = RawSubscriber(ros_context, {t: _types[t] for t in played})
    try:
        proc = start_play(tmp_path, request, str(bad), "--rate", "20", *START, "--topics", *played)
        _out, err = receive_until_exit(sub, proc, before)
    finally:
        sub.close()
    assert proc.returncode == 2, err
    assert_one_error_line(err, str(bad))
    # play did not read the whole bag first: what comes before the corrupt chunk was published
    assert sub.count() > 0, "nothing was published before the corrupt chunk"


def assert_one_error_line(err: str, path: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("drs-bag play: error:") and path in lines[0], err
    assert "Traceback" not in err


# ---- without DDS --------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["truncated", "not-mcap", "missing", "empty-dir"])
def test_an_unreadable_bag_exits_2_in_one_line(tmp_path, kind):
    require_rclpy()
    original = next(EXAMPLE.glob("*.mcap"))
    if kind == "truncated":
        bag = tmp_path / "truncated"
        bag.mkdir()
        (bag / "truncated_0.mcap").write_bytes(
            original.read_bytes()[: original.stat().st_size // 2]
        )
    elif kind == "not-mcap":
        bag = tmp_path / "notes.mcap"
        bag.write_text("this is not an MCAP file\n" * 10)
    elif kind == "missing":
        bag = tmp_path / "nowhere"
    else:
        bag = tmp_path / "empty"
        bag.mkdir()
    res = subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.replay.play", str(bag)],
        env=node_env(tmp_path, 0),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 2, res.stderr
    assert_one_error_line(res.stderr, str(bag) if kind != "truncated" else "truncated_0.mcap")


@pytest.mark.parametrize(
    "option, words",
    [
        (("--remap", "no-separator"), "OLD:=NEW"),
        (("--remap", "1 bad:=/x"), "remap rule"),
        (("--delay", "-1"), "--delay must be >= 0"),
        (("--start-offset", "nan"), "--start-offset"),
    ],
)
def test_an_invalid_option_exits_2_in_one_line(tmp_path, request, option, words):
    require_rclpy()
    res = subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.replay.play", str(EXAMPLE), *option],
        env=node_env(tmp_path, domain_for(request.node.nodeid)),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("drs-bag play: error:"), res.stderr
    assert words in lines[0]


def test_reading_streams_the_file_in_bounded_memory(tmp_path):
    """A 12 MB bag of 1 KiB messages in 64 KiB chunks: reading it through the player's reader
    must not hold more than a few chunks (an in-memory sort would hold all 12 MB)."""
    writer_mod = require_module("mcap.writer")
    from drs_ros.bag.replay.play import index_bag, iter_bag

    bag = tmp_path / "big.mcap"
    n, size = 12_000, 1024
    with open(bag, "wb") as f:
        writer = writer_mod.Writer(
            f, chunk_size=64 * 1024, compression=writer_mod.CompressionType.NONE
        )
        writer.start(profile="ros2", library="test_bag_play")
        schema = writer.register_schema(FLOAT64, "ros2msg", b"float64 data")
        cid = writer.register_channel("/big", "cdr", schema, {})
        for k in range(n):
            payload = k.to_bytes(4, "little") * (size // 4)
            writer.add_message(cid, log_time=10_000 + k * 1_000_000, data=payload, publish_time=k)
        writer.finish()
    assert bag.stat().st_size > n * size
    index = index_bag(bag)
    assert index.message_count == n
    tracemalloc.start()
    try:
        count, previous = 0, -1
        for _topic, t_ns, data in iter_bag(index, ["/big"]):
            assert t_ns > previous and int.from_bytes(data[:4], "little") == count
            previous, count = t_ns, count + 1
        _current, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert count == n
    assert peak < 2_000_000, peak  # bytes: a few 64 KiB chunks and their records, not 12 MB


def test_start_offset_skips_the_beginning(tmp_path):
    """``--start-offset`` starts reading that many seconds into the bag (the reader's part)."""
    from drs_ros.bag.replay.play import index_bag, iter_bag

    _types, messages = recorded(EXAMPLE)
    index = index_bag(EXAMPLE)
    cut = index.start_ns + 1_000_000_000
    got = [(t, d) for topic, t, d in iter_bag(index, ["/joint_states"], starting_at=cut)]
    want = [(t, d) for t, d in messages["/joint_states"] if t >= cut]
    assert got == want and 0 < len(want) < len(messages["/joint_states"])


def test_copy_of_the_example_bag_directory_plays_by_its_metadata(tmp_path):
    """A bag directory is read through its metadata.yaml's file list (the reader's resolver,
    which the player uses)."""
    from drs_ros.bag.read.files import BagReadError, resolve
    from drs_ros.bag.replay.play import index_bag

    copy = tmp_path / "copy"
    shutil.copytree(EXAMPLE, copy)
    files = tuple(copy / p.name for p in sorted(EXAMPLE.glob("*.mcap")))
    assert resolve(copy, require_metadata=False).files == files
    assert index_bag(copy).files == files
    (copy / next(EXAMPLE.glob("*.mcap")).name).unlink()
    with pytest.raises(BagReadError, match="which the bag directory does not hold"):
        index_bag(copy)


# ---- QoS as rosbag2 offers it -------------------------------------------------------------------
def offer(**changes) -> dict:
    import yaml

    base = yaml.safe_load(QOS_YAML)[0]
    base.update(changes)
    return base


def as_yaml(*offers) -> str:
    import yaml

    return yaml.safe_dump(list(offers))


def test_qos_of_identical_offers_is_the_first_with_default_history():
    require_rclpy()
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

    from drs_ros.bag.replay.play import playback_qos

    text = as_yaml(
        offer(durability="transient_local", depth=1, reliability="best_effort"),
        offer(durability="transient_local", depth=500, reliability="best_effort"),
    )
    qos, note = playback_qos(text, "/t")
    assert note is None
    assert qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert qos.reliability == ReliabilityPolicy.BEST_EFFORT
    assert (qos.history, qos.depth) == (HistoryPolicy.KEEP_LAST, 10)  # rosbag2's default_history
    assert qos.deadline.nanoseconds == 2**63 - 1


def test_qos_of_mixed_offers_or_none_is_the_default_with_a_warning():
    require_rclpy()
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    from drs_ros.bag.replay.play import playback_qos

    mixed = as_yaml(offer(durability="transient_local"), offer(durability="volatile"))
    qos, note = playback_qos(mixed, "/t")
    assert note is not None and "/t" in note
    assert (qos.reliability, qos.durability, qos.depth) == (
        ReliabilityPolicy.RELIABLE,
        DurabilityPolicy.VOLATILE,
        10,
    )
    for text in (None, "", "[]"):
        qos, note = playback_qos(text, "/t")
        assert note is None
        assert (qos.reliability, qos.durability, qos.depth) == (
            ReliabilityPolicy.RELIABLE,
            DurabilityPolicy.VOLATILE,
            10,
        )


def test_qos_of_an_old_bag_reads_integer_policies_and_foxy_infinity():
    """Metadata version <= 8 stores policies as integers; Foxy's Fast DDS wrote infinite as
    {sec: 2147483647, nsec: 4294967295}: rosbag2 reads both."""
    require_rclpy()
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    from drs_ros.bag.replay.play import playback_qos

    foxy = {"sec": 2147483647, "nsec": 4294967295}
    text = as_yaml(
        offer(
            history=1,
            reliability=2,
            durability=1,
            liveliness=1,
            deadline=foxy,
            lifespan=foxy,
            liveliness_lease_duration=foxy,
        )
    )
    qos, note = playback_qos(text, "/t")
    assert note is None
    assert qos.reliability == ReliabilityPolicy.BEST_EFFORT
    assert qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert qos.deadline.nanoseconds == 2**63 - 1


def test_qos_overrides_file_gives_partial_profiles_and_rejects_unknown_keys(tmp_path):
    require_rclpy()
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

    from drs_ros.bag.replay.play import PlayError, qos_overrides

    path = tmp_path / "overrides.yaml"
    path.write_text(
        "/a:\n  depth: 1000\n/b:\n  durability: transient_local\n"
        "  history: keep_all\n  deadline: {sec: 1, nsec: 5}\n"
    )
    table = qos_overrides(path)
    assert set(table) == {"/a", "/b"}
    a, b = table["/a"], table["/b"]
    assert (a.history, a.depth, a.reliability, a.durability) == (
        HistoryPolicy.KEEP_LAST,
        1000,
        ReliabilityPolicy.RELIABLE,
        DurabilityPolicy.VOLATILE,
    )
    assert (b.history, b.durability) == (HistoryPolicy.KEEP_ALL, DurabilityPolicy.TRANSIENT_LOCAL)
    assert b.deadline.nanoseconds == 1_000_000_005
    path.write_text("/a:\n  dept: 3\n")
    with pytest.raises(PlayError, match="dept"):
        qos_overrides(path)


#: Plays ended by a SIGINT in the suite's test (50 in benchmarks/results/play_sigint.txt).
SIGINT_PLAYS = 16


@pytest.mark.slow
def test_sigints_at_random_moments_of_playback_each_end_it_cleanly(tmp_path, request):
    """With both cores busy, ``drs-bag play --loop`` is started :data:`SIGINT_PLAYS` times and
    each play is ended by a SIGINT at a random moment of its playback
    (tests/play_sigint_driver.py: the plays run in one process, the console entry each time):
    every one returns 0, in time, with nothing raised and no traceback. The handler only sets a
    flag; one that took a lock (``Event.set``) could deadlock when the signal came inside
    ``Event.wait``. A handler that failed 6 times in 20, as one did, passes 16 plays with
    probability 0.7 ** 16 = 0.3 %; the 50 plays of benchmarks/results/play_sigint.txt are the
    wider sample."""
    import json

    from test_node_robustness import _burn

    driver = Path(__file__).with_name("play_sigint_driver.py")
    burners = _burn(600.0)  # killed at the end; the cap only guards a crashed test run
    try:
        proc = subprocess.run(
            [sys.executable, str(driver), str(EXAMPLE), str(SIGINT_PLAYS), "24"],
            env=node_env(tmp_path, domain_for(request.node.nodeid)),
            capture_output=True,
            text=True,
            timeout=900,
        )
    finally:
        for b in burners:
            b.kill()
            b.wait()
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert len(rows) == SIGINT_PLAYS, proc.stderr[-3000:]
    assert [r for r in rows if r["rc"] != 0 or r["error"]] == []
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    moments = sorted(r["after_s"] for r in rows)
    assert moments[-1] - moments[0] > 0.4  # spread over the playback, not one instant


def test_the_stop_handler_play_installs_takes_no_lock(monkeypatch):
    """A signal handler runs in the main thread between two bytecodes, wherever that thread is:
    one that takes a lock (``threading.Event.set`` does) deadlocks when the thread already holds
    it (inside ``Event.wait``). The handler ``play`` installs for SIGINT and SIGTERM, traced while
    it runs, calls no lock method, and its stop is requested."""
    from drs_ros.bag.replay.play import player

    seen = {}

    def fake_play(options, stop):
        seen.update({sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)})
        return 0

    monkeypatch.setattr(player, "_prepare", lambda options: options)  # no bag to index
    monkeypatch.setattr(player, "_play", fake_play)
    assert player.play(None) == 0
    for sig, handler in seen.items():
        calls = []

        def trace(frame, event, arg, calls=calls):
            if event == "c_call":
                calls.append(f"{type(getattr(arg, '__self__', None)).__name__}.{arg.__name__}")

        sys.setprofile(trace)
        try:
            handler(sig, None)
        finally:
            sys.setprofile(None)
        assert [c for c in calls if "lock" in c.lower()] == [], calls
        assert handler.requested and handler.signal_name == sig.name
    # and play gave the signals back their handlers
    assert signal.getsignal(signal.SIGINT) is not seen[signal.SIGINT]
