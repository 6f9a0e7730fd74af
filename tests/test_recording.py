"""McapRecorder: a rosbag2-compatible MCAP bag, read back by independent readers."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from ros_support import JOINT_NAMES, require_module, require_rclpy, write_drs_bag

pytestmark = pytest.mark.ros
yaml = require_module("yaml")  # installed with the ros extra; skips (outside CI) without it

#: The field types that name no message, as rosbags' own .msg parser names its base types (not
#: drs_ros.recording.msgdefs' table): the reference the full text is built from here.
PRIMITIVES = frozenset(require_module("rosbags.typesys.msg").BASE_NAMES)


def _share(pkg: str) -> Path:
    return Path(sys.prefix) / "share" / pkg / "msg"


def independent_definition(name: str) -> str:
    """Build the rosbag2 full text from the .msg files, line by line (not via
    drs_ros.recording.msgdefs)."""
    seen: set[str] = set()

    def text_of(full: str) -> str:
        pkg, typ = full.split("/")[0], full.split("/")[-1]
        return (_share(pkg) / f"{typ}.msg").read_text()

    def deps(text: str, pkg: str) -> list[str]:
        out = set()
        for line in text.splitlines():
            body = line.split("#", 1)[0].strip()
            if not body:
                continue
            typ = body.split()[0].split("[")[0]
            if typ in PRIMITIVES or "<=" in typ:
                continue
            out.add(typ if "/" in typ else f"{pkg}/{typ}")
        return sorted(out)

    def walk(full: str) -> str:
        text = text_of(full)
        for dep in deps(text, full.split("/")[0]):
            if dep not in seen:
                seen.add(dep)
                text += "\n" + "=" * 80 + "\nMSG: " + dep + "\n" + walk(dep)
        return text

    return walk(name)


def json_hash(name: str) -> str:
    pkg, typ = name.split("/")[0], name.split("/")[-1]
    data = json.loads((_share(pkg) / f"{typ}.json").read_text())
    return next(h["hash_string"] for h in data["type_hashes"] if h["type_name"] == name)


@pytest.fixture
def bag(tmp_path, params):
    require_rclpy()
    rec, t, q, qd, force = write_drs_bag(tmp_path / "demo", params, n=120)
    return rec, t, q, qd, force


def test_bag_layout_and_metadata_yaml(bag):
    rec, t, *_ = bag
    assert rec.path == rec.bag_dir / "demo_0.mcap" and rec.path.is_file()
    text = (rec.bag_dir / "metadata.yaml").read_text()
    meta = yaml.safe_load(text)["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["ros_distro"] == "jazzy"
    assert meta["relative_file_paths"] == ["demo_0.mcap"]
    topics = meta["topics_with_message_count"]
    counts = {e["topic_metadata"]["name"]: e["message_count"] for e in topics}
    assert counts == {"/joint_states": t.size, "/drs/flap_gap": t.size, "/drs/piston_force": t.size}
    assert meta["message_count"] == 3 * t.size == meta["files"][0]["message_count"]
    assert meta["duration"]["nanoseconds"] == pytest.approx((t[-1] - t[0]) * 1e9, abs=2)
    for entry in meta["topics_with_message_count"]:
        tm = entry["topic_metadata"]
        assert tm["type_description_hash"] == json_hash(tm["type"])
        assert tm["offered_qos_profiles"][0]["reliability"] == "reliable"
    assert rec.stats().messages == counts


def test_mcap_records_as_rosbag2_writes_them(bag):
    from mcap.reader import make_reader

    rec, t, *_ = bag
    with open(rec.path, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        assert header.profile == "ros2"
        schemas = {s.name: s for s in summary.schemas.values()}
        assert set(schemas) == {"sensor_msgs/msg/JointState", "std_msgs/msg/Float64"}
        for name, schema in schemas.items():
            assert schema.encoding == "ros2msg"
            assert schema.data.decode() == independent_definition(name)
        assert len(summary.schemas) == 2  # Float64 shared by two channels
        for channel in summary.channels.values():
            assert channel.message_encoding == "cdr"
            schema_name = summary.schemas[channel.schema_id].name
            assert channel.metadata["topic_type_hash"] == json_hash(schema_name)
            qos = yaml.safe_load(channel.metadata["offered_qos_profiles"])
            assert qos[0]["history"] == "keep_last" and qos[0]["depth"] == 10
            assert qos[0]["deadline"] == {"sec": 9223372036, "nsec": 854775807}
        records = list(reader.iter_metadata())
        assert [m.name for m in records] == ["rosbag2"]
        inner = yaml.safe_load(records[0].metadata["serialized_metadata"])
        assert inner["message_count"] == 3 * t.size


def test_schema_text_of_diagnostics_matches_independent_build():
    require_rclpy()
    from drs_ros.recording import msgdefs

    for name in (
        "diagnostic_msgs/msg/DiagnosticArray",
        "sensor_msgs/msg/JointState",
        "trajectory_msgs/msg/JointTrajectory",
    ):
        assert msgdefs.full_definition(name) == independent_definition(name)
        assert msgdefs.type_hash(name) == json_hash(name)
    from sensor_msgs.msg import JointState

    assert msgdefs.full_definition(JointState) is msgdefs.full_definition("sensor_msgs/JointState")


def test_msgdefs_errors():
    from drs_ros.recording import msgdefs

    with pytest.raises(msgdefs.MessageDefinitionError, match="invalid message type name"):
        msgdefs.full_definition("JointState")
    with pytest.raises(msgdefs.MessageDefinitionError, match=r"no \.msg file for"):
        msgdefs.full_definition("no_such_pkg/msg/Nothing")
    with pytest.raises(msgdefs.MessageDefinitionError, match="expected a ROS message class"):
        msgdefs.type_name(int)


def test_rosbags_and_mcap_ros2_decode_the_same_values(bag):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    rec, t, q, qd, force = bag
    with open(rec.path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        js = [m for _, c, _, m in reader.iter_decoded_messages(topics=["/joint_states"])]
    np.testing.assert_array_equal(np.array([m.position for m in js]), q)
    np.testing.assert_array_equal(np.array([m.velocity for m in js]), qd)
    assert list(js[0].name) == list(JOINT_NAMES)
    assert math.isnan(js[0].effort[1])
    for source in (rec.path, rec.bag_dir):  # a bare .mcap and the bag directory
        with AnyReader([Path(source)]) as reader:
            conns = [c for c in reader.connections if c.topic == "/drs/piston_force"]
            values = [
                reader.deserialize(raw, c.msgtype).data
                for c, _, raw in reader.messages(connections=conns)
            ]
            np.testing.assert_array_equal(values, force)


def test_finish_is_idempotent_and_closes(tmp_path):
    require_rclpy()
    from std_msgs.msg import Float64

    from drs_ros.recording.errors import RecordingError
    from drs_ros.recording.mcap_recorder import McapRecorder

    rec = McapRecorder(tmp_path / "b", flush_thread=False)
    rec.register_topic("/x", Float64)
    rec.write("/x", Float64(data=1.0), 5)
    first = rec.finish()
    size = rec.path.stat().st_size
    assert rec.finish() == first and rec.path.stat().st_size == size
    assert rec.stats().finished
    with pytest.raises(RecordingError, match="is finished"):
        rec.write("/x", Float64(data=2.0), 6)


def test_a_removed_bag_file_is_an_io_error_at_the_next_flush(tmp_path):
    """The bag's directory removed while recording: writes into the unlinked file would succeed
    and vanish, so each flush checks that the open file is still linked. The error is kept
    (``io_error``), every later write raises an OSError, a finish names what it could not write,
    and ``abandon`` closes a failed file without writing more."""
    require_rclpy()
    import shutil

    from std_msgs.msg import Float64

    from drs_ros.recording.errors import RecordingError
    from drs_ros.recording.mcap_recorder import McapRecorder

    rec = McapRecorder(tmp_path / "b", flush_thread=False, flush_messages=10)
    rec.register_topic("/x", Float64)
    for k in range(25):
        rec.write("/x", Float64(data=float(k)), k)
    shutil.rmtree(tmp_path / "b")
    with pytest.raises(FileNotFoundError, match="the bag file was removed while recording"):
        for k in range(25, 40):
            rec.write("/x", Float64(data=float(k)), k)
    assert isinstance(rec.io_error, FileNotFoundError)
    with pytest.raises(OSError, match="the bag failed earlier"):
        rec.write("/x", Float64(data=0.0), 99)
    with pytest.raises(
        RecordingError,
        match=r"its summary and footer \(.*\) and metadata\.yaml "
        r"\(No such file or directory\) could not be written",
    ):
        rec.finish()

    kept = McapRecorder(tmp_path / "c", flush_thread=False, flush_messages=10)
    kept.register_topic("/x", Float64)
    for k in range(25):
        kept.write("/x", Float64(data=float(k)), k)
    size = kept.path.stat().st_size
    kept.abandon()
    assert kept.path.stat().st_size == size and not kept.metadata_path.exists()
    with pytest.raises(RecordingError, match="is finished"):
        kept.write("/x", Float64(data=0.0), 99)


def test_recorder_errors(tmp_path):
    require_rclpy()
    from std_msgs.msg import Float64, String

    from drs_ros.recording.errors import RecordingError
    from drs_ros.recording.mcap_recorder import McapRecorder

    with pytest.raises(RecordingError, match="flush_period must be a finite number > 0"):
        McapRecorder(tmp_path / "a", flush_period=0.0)
    with pytest.raises(RecordingError, match="compression must be one of"):
        McapRecorder(tmp_path / "a", compression="gzip")
    with McapRecorder(tmp_path / "a", flush_thread=False) as rec:
        rec.register_topic("/x", Float64)
        with pytest.raises(RecordingError, match="not registered"):
            rec.write("/y", Float64(data=1.0), 1)
        with pytest.raises(RecordingError, match="carries std_msgs/msg/Float64"):
            rec.write("/x", String(data="no"), 1)
        with pytest.raises(RecordingError, match="log_time_ns must be an int"):
            rec.write("/x", Float64(data=1.0), 1.5)
        with pytest.raises(RecordingError, match="absolute name"):
            rec.register_topic("x", Float64)
        with pytest.raises(RecordingError, match="is registered with type"):
            rec.register_topic("/x", String)
    with pytest.raises(RecordingError, match="already holds files"):
        McapRecorder(tmp_path / "a")


def test_concurrent_writers_and_periodic_flush(tmp_path):
    require_rclpy()
    from std_msgs.msg import Float64

    from drs_ros.recording.mcap_recorder import McapRecorder

    per_thread, n_threads = 300, 4
    with McapRecorder(tmp_path / "c", flush_messages=100, flush_thread=False) as rec:
        for k in range(n_threads):
            rec.register_topic(f"/t{k}", Float64)

        def work(k):
            for i in range(per_thread):
                rec.write(f"/t{k}", Float64(data=float(i)), i)

        threads = [threading.Thread(target=work, args=(k,)) for k in range(n_threads)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        stats = rec.stats()
    total = per_thread * n_threads
    assert stats.message_count == total
    assert stats.flush_count == total // 100  # one flush per 100 messages
    assert stats.messages == {f"/t{k}": per_thread for k in range(n_threads)}


CHILD = textwrap.dedent(
    """
    import sys, time
    from std_msgs.msg import Float64
    from drs_ros.recording.mcap_recorder import McapRecorder
    rec = McapRecorder(sys.argv[1], flush_period=0.2)
    rec.register_topic("/x", Float64)
    i, flushed = 0, 0
    while True:
        rec.write("/x", Float64(data=float(i)), i)
        i += 1
        st = rec.stats()
        if st.flush_count != flushed:
            flushed = st.flush_count
            print(st.messages_flushed, flush=True)
        time.sleep(0.001)
    """
)


@pytest.mark.slow
def test_sigkill_leaves_a_recoverable_prefix(tmp_path):
    require_rclpy()
    from mcap.records import Message
    from mcap.stream_reader import StreamReader

    bag_dir = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(bag_dir)],
        stdout=subprocess.PIPE,
        text=True,
        env=dict(os.environ),
        cwd=str(Path(__file__).resolve().parents[1]),
    )
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    time.sleep(1.5)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    reader.join(timeout=5)
    assert proc.returncode == -signal.SIGKILL
    assert lines, "the child never flushed"
    flushed = int(lines[-1])
    recovered = []
    with open(bag_dir / "killed_0.mcap", "rb") as f:
        with pytest.raises(Exception):  # noqa: B017 - the file ends mid-way: any read error
            for record in StreamReader(f, validate_crcs=True).records:
                if isinstance(record, Message):
                    recovered.append(record.log_time)
    assert len(recovered) >= flushed > 0
    assert recovered == list(range(len(recovered)))  # the prefix, in order, nothing lost before it
    assert not (bag_dir / "metadata.yaml").exists()


def test_write_many_is_write_for_each_and_refuses_a_bad_record_before_writing(tmp_path):
    """A tick's records under one lock: the same file as one write each (sequence numbers,
    times, statistics, metadata.yaml); a record of an unregistered topic refuses the batch
    before any of it is written."""
    require_rclpy()
    from std_msgs.msg import Float64

    from drs_ros.recording import cdr
    from drs_ros.recording.errors import RecordingError
    from drs_ros.recording.mcap_recorder import McapRecorder

    pack = cdr.flat_packer(Float64)
    ticks = [
        [("/a", pack(float(k))), ("/b", pack(-float(k))), ("/a", pack(0.5 * k))] for k in range(40)
    ]
    files = []
    for many in (False, True):
        # chunks closed by size (the schedule counts a batch at once, so it is kept out)
        with McapRecorder(
            tmp_path / f"m{many}" / "bag", flush_thread=False, flush_period=10.0, chunk_size=300
        ) as rec:
            rec.register_topic("/a", Float64)
            rec.register_topic("/b", Float64)
            for k, records in enumerate(ticks):
                if many:
                    assert rec.write_many(records, 1000 + k) == [2 * k + 1, k + 1, 2 * k + 2]
                else:
                    for topic, data in records:
                        rec.write(topic, data, 1000 + k)
            if many:
                before = rec.stats().message_count
                with pytest.raises(RecordingError, match="'/c' is not registered"):
                    rec.write_many([("/a", pack(1.0)), ("/c", pack(2.0))], 5000)
                assert rec.stats().message_count == before
        files.append(((rec.path).read_bytes(), rec.metadata_path.read_text()))
    assert files[0] == files[1]
