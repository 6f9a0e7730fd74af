"""Helpers for tests that need rclpy (message classes and serialisation) and recorded bags.

``require_rclpy()`` skips a test only when rclpy is missing AND ``CI`` is not set; under CI a
missing rclpy fails the test. None of these helpers starts rclpy (no ``rclpy.init``, no DDS).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

JOINT_NAMES = ("drs_piston", "drs_link", "drs_flap")


def require_module(name: str):
    """Import ``name`` (installed by ``make test``), or skip outside CI / fail under CI."""
    import importlib

    try:
        return importlib.import_module(name)
    except ImportError as exc:
        if os.environ.get("CI"):
            pytest.fail(f"{name} is required under CI but cannot be imported: {exc}")
        pytest.skip(f"{name} is not installed: {exc}", allow_module_level=True)


def require_rclpy():
    """Import rclpy, or skip (outside CI) / fail (under CI) the calling test."""
    try:
        import rclpy  # noqa: F401
        import rclpy.serialization
    except ImportError as exc:
        if os.environ.get("CI"):
            pytest.fail(f"rclpy is required under CI but cannot be imported: {exc}")
        pytest.skip(f"rclpy is not installed: {exc}", allow_module_level=True)
    return rclpy


def manoeuvre_states(params, n: int = 200):
    """``t`` [s], ``q``, ``qd`` of the seed manoeuvre sampled at ``n`` instants (model output)."""
    from drs_model.kinematics import kinematic_state
    from drs_model.profile import drs_manoeuvre

    man = drs_manoeuvre(params)
    t = np.linspace(0.0, man.t_end, n)
    s, v, a = man.evaluate(t)
    state = kinematic_state(s, v, a, params)
    return t, state.q, state.qd


def write_drs_bag(
    bag_dir, params, *, n: int = 200, corrupt=None, recorder_kwargs=None, samples=None
):
    """Record a manoeuvre as the node would: /joint_states, /drs/flap_gap, /drs/piston_force.

    Parameters
    ----------
    corrupt : tuple (index, joint, delta), optional
        Add ``delta`` to the logged position of ``joint`` (0..2) of sample ``index``.
    samples : range, optional
        Record only these of the ``n`` samples (one file of a split recording); all by default.

    Returns
    -------
    (McapRecorder, t, q, qd, force)
    """
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from drs_model.kinematics import gap
    from drs_ros.recording.mcap_recorder import McapRecorder

    t, q, qd = manoeuvre_states(params, n)
    force = 1000.0 * np.sin(2 * np.pi * t / t[-1])  # a stand-in force, consistent across topics
    gaps = gap(q, params)
    q_logged = q.copy()
    if corrupt is not None:
        i, j, delta = corrupt
        q_logged[i, j] += delta
    t0_ns = 1_700_000_000_000_000_000
    kwargs = {"flush_thread": False, **(recorder_kwargs or {})}
    with McapRecorder(bag_dir, **kwargs) as rec:
        rec.register_topic("/joint_states", JointState, 10)
        rec.register_topic("/drs/flap_gap", Float64, 10)
        rec.register_topic("/drs/piston_force", "std_msgs/msg/Float64", 10)
        for k in range(n) if samples is None else samples:
            ns = t0_ns + int(round(t[k] * 1e9))
            msg = JointState()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
            msg.name = list(JOINT_NAMES)
            msg.position = [float(x) for x in q_logged[k]]
            msg.velocity = [float(x) for x in qd[k]]
            msg.effort = [float(force[k]), float("nan"), float("nan")]
            rec.write("/joint_states", msg, ns)
            rec.write("/drs/flap_gap", Float64(data=float(gaps[k])), ns)
            rec.write("/drs/piston_force", Float64(data=float(force[k])), ns)
    return rec, t, q, qd, force


def mcap_to_db3(src, dst, max_messages: int | None = None):
    """Copy an MCAP bag (a file or a bag directory of one file) into a new rosbag2 sqlite3 bag
    directory ``dst`` with rosbags' writer (an independent writer: the bytes, topics, types,
    definitions and hashes as recorded); ``max_messages`` stops early. Returns ``dst``."""
    from pathlib import Path

    from mcap.reader import make_reader
    from rosbags.rosbag2 import StoragePlugin, Writer

    src = Path(src)
    path = next(src.glob("*.mcap")) if src.is_dir() else src
    with open(path, "rb") as f, Writer(dst, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        reader = make_reader(f)
        summary = reader.get_summary()
        conns = {}
        for cid, ch in summary.channels.items():
            schema = summary.schemas[ch.schema_id]
            rihs01 = ch.metadata.get("topic_type_hash") or "RIHS01_" + "0" * 64
            conns[cid] = w.add_connection(
                ch.topic,
                schema.name,
                msgdef=schema.data.decode(),
                rihs01=rihs01,
                serialization_format=ch.message_encoding,
            )
        messages = reader.iter_messages(log_time_order=False)  # the file's order, kept
        for n, (_schema, channel, message) in enumerate(messages):
            if max_messages is not None and n >= max_messages:
                break
            w.write(conns[channel.id], message.log_time, message.data)
    return Path(dst)


def write_split_bag(tmp_path, params, *, killed: bool, n: int = 240):
    """A bag split as rosbag2 splits it, ``split/split_0.mcap`` (samples 0..n/2) and
    ``split/split_1.mcap`` (the rest); ``killed``: the second file cut at 60 % and no
    metadata.yaml (the recorder was SIGKILLed while writing it). Returns the bag and the number
    of messages of the first file."""
    import yaml

    half = n // 2
    parts = []
    for i, samples in enumerate((range(0, half), range(half, n))):
        rec, *_ = write_drs_bag(
            tmp_path / f"part{i}",
            params,
            n=n,
            samples=samples,
            recorder_kwargs={"flush_messages": 45},
        )
        parts.append(rec)
    bag = tmp_path / "split"
    bag.mkdir()
    for i, rec in enumerate(parts):
        data = rec.path.read_bytes()
        if killed and i == 1:
            data = data[: int(len(data) * 0.6)]
        (bag / f"split_{i}.mcap").write_bytes(data)
    if not killed:
        metas = [rec.bag_metadata() for rec in parts]
        meta = metas[0]
        for topic, other in zip(
            meta["topics_with_message_count"], metas[1]["topics_with_message_count"], strict=True
        ):
            topic["message_count"] += other["message_count"]
        meta["message_count"] += metas[1]["message_count"]
        end = (
            metas[1]["starting_time"]["nanoseconds_since_epoch"]
            + metas[1]["duration"]["nanoseconds"]
        )
        meta["duration"]["nanoseconds"] = end - meta["starting_time"]["nanoseconds_since_epoch"]
        meta["relative_file_paths"] = ["split_0.mcap", "split_1.mcap"]
        meta["files"] = []
        (bag / "metadata.yaml").write_text(
            yaml.safe_dump({"rosbag2_bagfile_information": meta}, sort_keys=False)
        )
    return bag, 3 * half


def resimulate_json(*args) -> tuple[int, dict]:
    """``drs-bag resimulate ARGS --json`` as a process: its exit status (0 or 1, asserted) and
    its report."""
    import json
    import subprocess
    import sys

    res = subprocess.run(
        [sys.executable, "-m", "drs_ros.bag.cli", "resimulate", *args, "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode in (0, 1), res.stderr
    return res.returncode, json.loads(res.stdout)


def tampered_copy(bag, out, change) -> int:
    """Copy ``bag`` into the new bag ``out`` (MCAP, as rosbag2 writes it) with some messages
    changed: ``change(topic, index, msg)`` (``index``: the message's place among its topic's,
    ``msg`` decoded) returns the message to write instead, or None to keep the recorded bytes.
    Every changed message is serialised again, so the copy is a valid bag whose CDR is exact:
    only the model checks can tell. Returns the number of messages changed."""
    from message_support import serialize

    from drs_ros.bag.read.decoded import decoder
    from drs_ros.bag.read.reader import scan
    from drs_ros.bag.recover import _register
    from drs_ros.recording.mcap_recorder import McapRecorder

    decode = decoder()
    seen: dict[str, int] = {}
    changed = [0]
    with McapRecorder(out, flush_thread=False) as rec:

        def copy(m) -> None:
            if m.topic not in rec.topics:
                _register(rec, m.channel)
            index = seen[m.topic] = seen.get(m.topic, -1) + 1
            new = change(m.topic, index, decode(m))
            data = m.data if new is None else serialize(new)
            changed[0] += new is not None
            rec.write(m.topic, data, m.log_time, m.publish_time, sequence=m.sequence)

        scan(bag, copy)
    return changed[0]
