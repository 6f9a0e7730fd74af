"""Each recording of the node owns its failure, and every failure is seen
(drs_ros.node.recordings): a rerun recording cut by a full file system, a bag whose directory is
removed, a write that raises, a finish that fails. The node runs on, says so in diagnostics, and
``drs-node`` exits 1 naming what each incomplete recording lacks, while the other recording is
complete (``drs-bag check``, ``rerun rrd verify``)."""

from __future__ import annotations

import shutil
import time

import pytest
from fs_support import small_filesystem
from node_support import domain_for, spin_until, wait_for_file_growth
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

require_rclpy()

from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from test_node_robustness import bag_check, start_node, stop_node  # noqa: E402

from drs_ros.client import DRSClient  # noqa: E402
from drs_ros.node import DRSNode  # noqa: E402
from drs_ros.recording.rerun_cli import run_rerun_cli  # noqa: E402


def errors(watcher: DRSClient) -> list:
    """The node's diagnostics at ERROR that ``watcher`` kept, as {key: value} with the
    message."""
    return [
        {"message": s.message, **{kv.key: kv.value for kv in s.values}}
        for s in watcher.diagnostic_statuses
        if s.level == DiagnosticStatus.ERROR
    ]


def states_keep_coming(watcher: DRSClient, seconds: float = 1.0) -> bool:
    n = len(watcher.joint_state_msgs)
    watcher.spin(seconds)
    return len(watcher.joint_state_msgs) > n + 10


@pytest.mark.slow
def test_a_full_file_system_cuts_the_rrd_and_the_bag_goes_on(tmp_path, request):
    """The .rrd on a 128 KiB file system fills it a few seconds in: rerun's writer reports it in
    its own log only, yet the node sees it (diagnostics at ERROR, naming the file and the full
    file system), keeps publishing and recording the bag, and at SIGINT exits 1 naming the .rrd
    whose end is missing. The bag passes ``drs-bag check``; ``rerun rrd verify`` confirms the
    .rrd is cut (what the node reports)."""
    domain = domain_for(request.node.nodeid)
    bag, rrd = tmp_path / "bag", tmp_path / "small" / "run.rrd"
    with small_filesystem(tmp_path / "small", 128 * 1024):
        proc = start_node(tmp_path, domain, f"bag_path:={bag}", f"rrd_path:={rrd}")
        watcher = DRSClient(domain, keep=True, listen=("joint_states", "diagnostics"))
        try:
            assert watcher.wait_for(lambda: errors(watcher), timeout=90), "no ERROR diagnostics"
            error = errors(watcher)[-1]
            assert f"rerun recording '{rrd}' stopped" in error["message"]
            assert "file writer stopped" in error["rerun"] and "0 bytes are free" in error["rerun"]
            assert error["bag"].endswith("flushes")  # the bag goes on, unharmed
            assert states_keep_coming(watcher)
        finally:
            watcher.close()
            out = stop_node(proc)
        assert proc.returncode == 1, out[-3000:]
        assert f"drs-node: the rerun recording '{rrd}' is incomplete, its end is missing" in out
        assert "recordings incomplete" in out and "bag" not in out.split("drs-node:")[-2]
        verify = run_rerun_cli(["rrd", "verify", str(rrd)])
        assert verify.returncode != 0  # cut indeed
    assert bag_check(bag) == 0


@pytest.mark.slow
def test_a_removed_bag_is_named_and_the_rrd_is_complete(tmp_path, request):
    """The bag's directory removed mid-run: the next flush finds its file unlinked, the node says
    so (diagnostics at ERROR), runs on, and exits 1 naming the bag; the .rrd is complete."""
    domain = domain_for(request.node.nodeid)
    bag, rrd = tmp_path / "bag", tmp_path / "run.rrd"
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", f"rrd_path:={rrd}", "flush_period:=0.2")
    watcher = DRSClient(domain, keep=True, listen=("joint_states", "diagnostics"))
    try:
        assert wait_for_file_growth(bag / "bag_0.mcap", timeout=60, min_size=50_000)
        shutil.rmtree(bag)
        assert watcher.wait_for(lambda: errors(watcher), timeout=30), "no ERROR diagnostics"
        error = errors(watcher)[-1]
        assert f"bag '{bag}' stopped" in error["message"] and "removed" in error["message"]
        assert error["rerun"].endswith("samples")
        assert states_keep_coming(watcher)
    finally:
        watcher.close()
        out = stop_node(proc)
    assert proc.returncode == 1, out[-3000:]
    assert f"drs-node: bag '{bag}' is lost" in out and "was removed while recording" in out
    assert not bag.exists()
    verify = run_rerun_cli(["rrd", "verify", str(rrd)])
    assert verify.returncode == 0, verify.stderr[-1000:]


def _run_in_process(ros_context, tmp_path, seconds: float, during=None) -> DRSNode:
    """A node with a bag and an .rrd, spun ``seconds``; ``during(node)`` after the first tick."""
    node = DRSNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("bag_path", value=str(tmp_path / "bag")),
            Parameter("rrd_path", value=str(tmp_path / "run.rrd")),
        ],
    )
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    try:
        assert spin_until(ex, lambda: node.effects.ticks > 5, 10.0)
        if during is not None:
            during(node)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.01)
    finally:
        ex.shutdown()
    return node


def test_a_raising_rerun_call_leaves_the_bag_complete(ros_context, tmp_path):
    """Every rerun logging call raises (a programming error, not I/O): each sample is lost,
    logged and counted (diagnostics WARN, ``rerun`` says how many), the rerun recording goes on
    trying, and the bag is complete; one bag write that raises loses that message only. The
    stop names both losses, each in its own recording."""
    from drs_ros.bag.read.reader import scan

    calls = {"bag": 0}

    def break_both(node):
        calls["before"] = node.recordings.recorder.stats().message_count

        def rerun_fails(*args):
            calls["rerun"] = calls.get("rerun", 0) + 1
            raise RuntimeError("rerun logging failed on purpose")

        node.recordings.rerun.log_state = rerun_fails
        real_write = node.recordings.recorder.write

        def bag_fails_once(topic, msg, **kw):
            calls["bag"] += 1
            if calls["bag"] == 1:
                raise TypeError("a bag write failed on purpose")
            return real_write(topic, msg, **kw)

        node.recordings.recorder.write = bag_fails_once
        real_many = node.recordings.recorder.write_many

        def bag_many(records, log_time_ns):  # a tick's states: the first batch refused
            if not calls.get("refused"):  # (written record by record, the first write fails)
                calls["refused"] = True
                raise TypeError("a tick's batch refused on purpose")
            calls["bag"] += len(records)
            return real_many(records, log_time_ns)

        node.recordings.recorder.write_many = bag_many

    node = _run_in_process(ros_context, tmp_path, 1.0, during=break_both)
    try:
        values = node.diagnostics_values()
        level, message = node.diagnostics_level(node._now_ns())
        lines = node.close_recordings()
    finally:
        node.destroy_node()
    lost = calls["rerun"]  # every call the broken rerun logging was asked for, one item each
    assert 100 < lost <= node.effects.ticks - 6  # it went on trying, once a tick at most
    assert (
        "items not recorded (last: RuntimeError: rerun logging failed on purpose)"
        in (values["rerun"])
    )
    assert "; 1 items not recorded (last: TypeError" in values["bag"]
    assert level == DiagnosticStatus.WARN and "recording error" in message
    assert len(lines) == 2
    rerun_line, bag_line = lines
    assert rerun_line.startswith(f"rerun recording '{tmp_path / 'run.rrd'}' lacks")
    assert int(rerun_line.split(" lacks ")[1].split()[0]) == lost
    assert bag_line.startswith(f"bag '{tmp_path / 'bag'}' lacks 1 items") and "TypeError" in (
        bag_line
    )
    assert bag_check(tmp_path / "bag") == 0
    # every message but the one lost, in a bag that reads to its end
    assert scan(tmp_path / "bag").message_count == calls["before"] + calls["bag"] - 1
    assert calls["bag"] > 100


def test_a_finish_that_fails_names_what_is_missing(ros_context, tmp_path):
    """``metadata.yaml`` cannot be written (a directory took its name): the bag's file is
    finished (its summary read by the reader), and the stop names metadata.yaml and why."""
    from drs_ros.bag.read.reader import scan

    node = _run_in_process(
        ros_context, tmp_path, 0.5, during=lambda n: (tmp_path / "bag" / "metadata.yaml").mkdir()
    )
    try:
        lines = node.close_recordings()
        assert node.close_recordings() == lines  # idempotent, the lines kept
    finally:
        node.destroy_node()
    (line,) = lines
    assert line == (
        f"bag '{tmp_path / 'bag'}' is incomplete: metadata.yaml (Is a directory) "
        "could not be written"
    )
    assert scan(tmp_path / "bag" / "bag_0.mcap").complete
    assert run_rerun_cli(["rrd", "verify", str(tmp_path / "run.rrd")]).returncode == 0


def test_a_tick_batch_with_a_bad_record_loses_that_record_only(tmp_path):
    """The bag refuses a tick's batch naming an unregistered topic before writing any of it:
    the node's bag then writes the batch record by record, so the good records are kept and
    the bad one is lost and counted."""
    import logging

    from std_msgs.msg import Float64

    from drs_ros.bag.read.reader import scan
    from drs_ros.node.recordings import BagRecording
    from drs_ros.recording import cdr
    from drs_ros.recording.mcap_recorder import McapRecorder

    pack = cdr.flat_packer(Float64)
    rec = McapRecorder(tmp_path / "bag", flush_thread=False)
    rec.register_topic("/a", Float64)
    bag = BagRecording(rec, logging.getLogger("test"))
    bag.write_many([("/a", pack(1.0)), ("/nowhere", pack(2.0)), ("/a", pack(3.0))], 10)
    bag.write_many([("/a", pack(4.0))], 11)
    assert bag.health.errors == 1 and "'/nowhere' is not registered" in bag.health.last_error
    (line,) = bag.finish()
    assert line.startswith(f"bag '{tmp_path / 'bag'}' lacks 1 items") and "/nowhere" in line
    assert scan(tmp_path / "bag").message_count == 3


class Lines:
    """A logger that keeps its lines (the node's logger's calls: ``error(msg, **kw)``)."""

    def __init__(self):
        self.lines: list[str] = []

    def error(self, msg, **kw):
        self.lines.append(msg)


@pytest.mark.parametrize(
    "error",
    [RuntimeError("rerun refused a batch on purpose"), OSError(28, "No space left on device")],
)
def test_a_batch_the_rerun_sender_fails_reaches_the_health_not_the_tick(tmp_path, params, error):
    """rerun's send_columns raises in the recorder's sender thread for the second batch: the
    tick-side log_state never raises, and the next one takes the failure in: a RuntimeError
    counts its ten states lost (diagnostics, the window's trouble, the stop's line); an OSError
    stops the recording (diagnostics 'failed', the stop says it is incomplete)."""
    from test_rerun_recorder import held_send_columns

    from drs_ros.node.recordings import RerunRecording
    from drs_ros.recording.rerun_recorder import RerunRecorder

    rec = RerunRecorder(tmp_path / "run.rrd", params, batch=10)
    release = held_send_columns(rec, fail_batch=1, error=error)
    release.set()
    logger, lost = Lines(), []
    part = RerunRecording(rec, logger, lost.append)
    for k in range(25):
        part.log_state(k * 1e-3, [0.01, 0.5, 0.6], 1.0)
    rec.flush()  # the sender has met the failure; the next tick takes it in
    part.log_state(0.025, [0.01, 0.5, 0.6], 1.0)
    if isinstance(error, OSError):
        assert part.health.failure == "OSError: [Errno 28] No space left on device"
        assert part.status().startswith("failed: OSError")
        assert part.finish() == [
            f"{part.health.name} is incomplete: recording stopped "
            f"(OSError: [Errno 28] No space left on device)"
        ]
    else:
        assert part.health.errors == 10 and not part.health.failure
        assert part.status().endswith(
            "10 items not recorded (last: RuntimeError: rerun refused a batch on purpose)"
        )
        assert lost == [f"{part.health.name}: RuntimeError: rerun refused a batch on purpose"]
        assert "10 items were not recorded" in logger.lines[0] and "Traceback" in logger.lines[0]
        name = part.health.name
        assert part.finish() == [
            f"{name} lacks 10 items that could not be recorded (last: "
            "RuntimeError: rerun refused a batch on purpose)"
        ]


@pytest.mark.parametrize(
    ("path", "cycle", "keep_suffix", "expected"),
    [
        ("runs/a", 0, False, "runs/a"),
        ("runs/a", 1, False, "runs/a_1"),
        ("runs/a.v2", 12, False, "runs/a.v2_12"),  # a bag directory: its whole name
        ("runs/a/", 2, False, "runs/a_2"),
        ("runs/run.rrd", 0, True, "runs/run.rrd"),
        ("runs/run.rrd", 3, True, "runs/run_3.rrd"),
        ("run", 1, True, "run_1"),
        ("", 4, False, ""),  # nothing recorded stays nothing
    ],
)
def test_each_configure_of_a_managed_node_records_to_its_own_name(
    path, cycle, keep_suffix, expected
):
    """The first cycle records to the parameter's path, the n-th later one to that name with
    ``_n`` appended (before an .rrd's suffix), as docs/ros.md says."""
    from drs_ros.node.recordings import cycle_path

    assert cycle_path(path, cycle, keep_suffix) == expected
