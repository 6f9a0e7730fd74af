"""RerunRecorder: the .rrd reads back with the entities and scalar rows that were logged; a live
stream reaches a rerun gRPC server on loopback with the same data as the file."""

from __future__ import annotations

import re
import socket
import subprocess
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from ros_support import manoeuvre_states, require_module  # noqa: E402

rr = require_module("rerun")

from drs_model import kinematics  # noqa: E402
from drs_ros.recording.destinations import check_connect_url  # noqa: E402
from drs_ros.recording.errors import RerunLogError  # noqa: E402
from drs_ros.recording.rerun_recorder import (  # noqa: E402
    DRAWINGS,
    SERIES,
    TIMELINE,
    RerunRecorder,
)

#: A server writes what it receives without a footer; rerun's reader then warns and scans.
no_footer = pytest.mark.filterwarnings("ignore:RRD file has no footer")


def read_rows(path) -> tuple[Counter, Counter]:
    """Rows per entity holding Scalars data, and rows per entity holding any other data."""
    from rerun.chunk import RrdReader

    scalars, other = Counter(), Counter()
    for chunk in RrdReader(str(path)).stream().to_chunks():
        batch = chunk.to_record_batch()
        names = batch.schema.names
        entity = chunk.entity_path
        col = next((n for n in names if n.startswith("Scalars:scalars")), None)
        if col is not None:
            scalars[entity] += batch.num_rows - batch.column(col).null_count
        elif any(n.startswith(("LineStrips2D:strips", "Points2D:positions")) for n in names):
            other[entity] += batch.num_rows
    return scalars, other


def test_log_trajectory_round_trip(tmp_path, params):
    t, q, _ = manoeuvre_states(params, 400)
    force = np.linspace(-1.0, 1.0, t.size) * 1e3
    force[5] = np.nan  # an unknown force is not plotted
    path = tmp_path / "run.rrd"
    with RerunRecorder(path, params, max_draw_hz=250.0) as rec:
        drawn = rec.log_trajectory(t, q, force)
    expected_draws = 1 + int(np.floor(t[-1] * 250.0 + 1e-9))
    assert drawn == rec.draw_count
    assert abs(drawn - expected_draws) <= 1 and drawn < t.size
    scalars, other = read_rows(path)
    for entity in SERIES:
        n = t.size - 1 if entity == "series/piston_force" else t.size
        assert scalars["/" + entity] == n == rec.scalar_rows[entity]
    for entity in DRAWINGS:
        assert other["/" + entity] == drawn
    for entity in ("mechanism/fia_box", "mechanism/main_wing", "mechanism/pylon"):
        assert other["/" + entity] == 1  # static


def test_log_state_streams_with_decimation(tmp_path, params):
    t, q, _ = manoeuvre_states(params, 101)  # 0.5 ms steps: 2 kHz
    path = tmp_path / "stream.rrd"
    rec = RerunRecorder(path, params, max_draw_hz=500.0, batch=16)
    flags = [rec.log_state(ti, qi, 10.0 * i) for i, (ti, qi) in enumerate(zip(t, q, strict=True))]
    rec.close()
    rec.close()  # idempotent
    assert sum(flags) == rec.draw_count
    assert rec.draw_count == len(range(0, t.size, 4))  # every 4th sample at 500 Hz
    scalars, other = read_rows(path)
    assert all(scalars["/" + e] == t.size for e in SERIES)
    assert all(other["/" + e] == rec.draw_count for e in DRAWINGS)
    with pytest.raises(RerunLogError, match="is closed"):
        rec.log_state(1.0, q[0])


def test_rerun_input_errors(tmp_path, params):
    with pytest.raises(RerunLogError, match="max_draw_hz must be a finite number > 0"):
        RerunRecorder(tmp_path / "x.rrd", params, max_draw_hz=0.0)
    with RerunRecorder(tmp_path / "y.rrd", params) as rec:
        with pytest.raises(RerunLogError, match=r"t must have shape \(n,\) and q \(n, 3\)"):
            rec.log_trajectory([0.0, 1.0], np.zeros((3, 3)))
        with pytest.raises(RerunLogError, match="non-decreasing"):
            rec.log_trajectory([1.0, 0.0], np.zeros((2, 3)))
        with pytest.raises(RerunLogError, match=r"q must hold \[s, psi1, psi3\]"):
            rec.log_state(0.0, [0.0, 0.0])
        with pytest.raises(RerunLogError, match="t must be a finite time"):
            rec.log_state(float("nan"), [0.0, 0.0, 0.0])  # refused alone, not its whole batch


# ---- live streaming ---------------------------------------------------------------------------
def read_series(path, entity: str) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and values of the scalar series ``entity`` in an .rrd, in time order."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    times, values = [], []
    for chunk in RrdReader(str(path)).stream().to_chunks():
        if chunk.entity_path != entity:
            continue
        batch = chunk.to_record_batch()
        col = next((n for n in batch.schema.names if n.startswith("Scalars:scalars")), None)
        if col is None:
            continue
        t_ns = batch.column(TIMELINE).cast(pa.int64()).to_numpy()
        for ti, row in zip(t_ns, batch.column(col).to_pylist(), strict=True):
            if row is not None:
                (value,) = row
                times.append(ti)
                values.append(value)
    order = np.argsort(times, kind="stable")
    return np.asarray(times)[order] * 1e-9, np.asarray(values, dtype=float)[order]


def free_loopback_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def wait_for(predicate, timeout: float = 20.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if predicate():
                return True
        except Exception:  # a file the server is still writing may end mid-chunk
            pass
        time.sleep(0.2)
    return predicate()


@pytest.fixture
def rerun_env(tmp_path, monkeypatch):
    """The rerun CLI binary installed with the SDK, with rerun's usage analytics off for this test
    and its server (they would leave loopback)."""
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "xdg-config"))
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg-data"))
    # The binary itself: `python -m rerun_cli` runs it as a grandchild that a signal to the
    # wrapper would not stop.
    cli = Path(require_module("rerun_cli").__file__).with_name("rerun")
    subprocess.run([cli, "analytics", "disable"], check=True, capture_output=True, timeout=60)
    return cli


@pytest.fixture
def rerun_server(tmp_path, rerun_env):
    """A rerun gRPC server on 127.0.0.1 that saves what it receives to an .rrd: yields (URL, path
    of that file)."""
    port = free_loopback_port()
    received = tmp_path / "received.rrd"
    log = tmp_path / "rerun-server.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen(
            [rerun_env, "--bind", "127.0.0.1", "--port", str(port), "--save", str(received)],
            stdout=out,
            stderr=subprocess.STDOUT,
        )

    def listening() -> bool:
        with socket.socket() as sock:
            return sock.connect_ex(("127.0.0.1", port)) == 0

    try:
        if not wait_for(lambda: proc.poll() is not None or listening(), timeout=30.0):
            pytest.fail("the rerun server did not listen within 30 s")
        assert proc.poll() is None, log.read_text()
        yield f"rerun+http://127.0.0.1:{port}/proxy", received
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


@no_footer
def test_streams_live_and_to_the_file_alike(tmp_path, params, rerun_server):
    url, received = rerun_server
    t, q, _ = manoeuvre_states(params, 300)
    force = np.linspace(-1.0, 1.0, t.size) * 1e3
    path = tmp_path / "tee.rrd"
    with RerunRecorder(path, params, connect_url=url, max_draw_hz=250.0) as rec:
        drawn = rec.log_trajectory(t, q, force)
    assert rec.stream_error is None
    in_file = read_rows(path)
    assert wait_for(lambda: read_rows(received) == in_file), (read_rows(received), in_file)
    scalars, other = in_file
    assert all(scalars["/" + e] == t.size for e in SERIES)
    assert all(other["/" + e] == drawn for e in DRAWINGS)
    # The values that arrived, against the model (not against what the recorder computed).
    for where in (received, path):
        t_gap, gap = read_series(where, "/series/gap")
        np.testing.assert_allclose(t_gap, t, rtol=0, atol=1e-9)
        np.testing.assert_allclose(gap, kinematics.gap(q, params), rtol=0, atol=1e-15)
        _, stroke = read_series(where, "/series/stroke")
        np.testing.assert_array_equal(stroke, q[:, 0])


@no_footer
def test_streams_live_without_a_file(tmp_path, params, rerun_server):
    url, received = rerun_server
    t, q, _ = manoeuvre_states(params, 101)
    rec = RerunRecorder(None, params, connect_url=url, max_draw_hz=500.0, batch=16)
    for ti, qi in zip(t, q, strict=True):
        rec.log_state(ti, qi, 5.0)
    rec.close()
    assert rec.path is None and rec.stream_error is None
    assert sorted(p.name for p in tmp_path.glob("*.rrd")) == ["received.rrd"]

    def arrived() -> bool:
        scalars, other = read_rows(received)
        return all(scalars["/" + e] == t.size for e in SERIES) and all(
            other["/" + e] == rec.draw_count for e in DRAWINGS
        )

    assert wait_for(arrived), read_rows(received)
    with pytest.raises(
        RerunLogError, match=r"rerun recorder of 'rerun\+http://127.0.0.1:\d+/proxy'"
    ):
        rec.log_state(1.0, q[0])


@pytest.mark.slow
def test_an_absent_viewer_loses_nothing_in_the_file(tmp_path, params, rerun_env):
    """Nobody listens at the URL: close() returns (within the SDK's timeouts), the file is whole
    and the reason is kept."""
    url = f"rerun+http://127.0.0.1:{free_loopback_port()}/proxy"
    t, q, _ = manoeuvre_states(params, 120)
    path = tmp_path / "alone.rrd"
    start = time.monotonic()
    with RerunRecorder(path, params, connect_url=url) as rec:
        rec.log_trajectory(t, q)
    assert time.monotonic() - start < 30.0
    assert rec.stream_error is not None and url in rec.stream_error
    scalars, _ = read_rows(path)
    assert all(scalars["/" + e] == t.size for e in SERIES if e != "series/piston_force")


@pytest.mark.parametrize(
    "url",
    [
        "rerun+http://127.0.0.1:9876/proxy",
        "rerun+http://localhost:9876/proxy",
        "rerun+https://[::1]:9876/proxy",
        "rerun://127.0.0.2:1/proxy",
    ],
)
def test_connect_url_on_loopback_is_accepted(url):
    assert check_connect_url(url) == url


@pytest.mark.parametrize(
    ("url", "reason"),
    [
        ("", "must be a non-empty string"),
        (9876, "must be a non-empty string"),
        ("http://127.0.0.1:9876/proxy", "the scheme must be one of rerun://"),
        ("127.0.0.1:9876", "the scheme must be one of"),
        ("rerun+http://:9876/proxy", "it names no host"),
        ("rerun+http://127.0.0.1/proxy", "it needs a port in 1..65535"),
        ("rerun+http://127.0.0.1:99999/proxy", "it needs a port in 1..65535"),
        ("rerun+http://127.0.0.1:abc/proxy", "it needs a port in 1..65535"),
        ("rerun+http://127.0.0.1:9876/", "the path must be /proxy"),
        ("rerun+http://127.0.0.1:9876/proxy?x=1", "no user, query or fragment"),
        ("rerun+http://user@127.0.0.1:9876/proxy", "no user, query or fragment"),
    ],
)
def test_malformed_connect_url_is_refused(tmp_path, params, url, reason):
    with pytest.raises(RerunLogError, match="(invalid rerun connect URL|rerun connect URL must)"):
        check_connect_url(url)
    with pytest.raises(RerunLogError, match=re.escape(reason)):
        RerunRecorder(tmp_path / "x.rrd", params, connect_url=url)
    assert not (tmp_path / "x.rrd").exists()


@pytest.mark.parametrize(
    ("url", "reason"),
    [
        ("rerun+http://192.168.1.10:9876/proxy", "host '192.168.1.10' is not on loopback"),
        ("rerun+http://0.0.0.0:9876/proxy", "host '0.0.0.0' is not on loopback"),
        ("rerun+http://[2001:db8::1]:9876/proxy", "host '2001:db8::1' is not on loopback"),
        ("rerun+http://viewer.example.com:9876/proxy", "is a name other than 'localhost'"),
    ],
)
def test_connect_url_off_loopback_is_refused(tmp_path, params, url, reason):
    with pytest.raises(RerunLogError, match="refused: .*" + re.escape(reason)):
        RerunRecorder(tmp_path / "x.rrd", params, connect_url=url)
    assert not (tmp_path / "x.rrd").exists()


def test_needs_a_file_or_a_url(params):
    with pytest.raises(RerunLogError, match="needs a path, a connect_url, or both"):
        RerunRecorder(None, params)


def test_a_full_file_system_is_seen_while_recording_and_named_at_close(tmp_path, params):
    """rerun's file writer meets ENOSPC on a 96 KiB tmpfs and reports it only in its own log;
    the recorder's watch sees it within a few periods (a flush raises once the writer has
    stopped), and close raises RerunSinkError naming the file and what it lacks."""
    from fs_support import small_filesystem

    from drs_ros.recording.rerun_sink import SINK_CHECK_PERIOD_S, RerunSinkError

    with small_filesystem(tmp_path / "small", 96 * 1024):
        path = tmp_path / "small" / "run.rrd"
        rec = RerunRecorder(path, params, batch=50)
        t, q, _ = manoeuvre_states(params, 200)
        k = 0
        end = time.monotonic() + 60.0
        while rec.sink_error is None and time.monotonic() < end:
            for i in range(200):
                rec.log_state(k * 1e-3, q[i], 100.0)
                k += 1
            time.sleep(SINK_CHECK_PERIOD_S / 5)
        assert rec.sink_error is not None and "file writer stopped" in rec.sink_error
        assert "0 bytes are free" in rec.sink_error
        with pytest.raises(
            RerunSinkError,
            match=rf"'{re.escape(str(path))}' is incomplete, its "
            r"end is missing: rerun's file writer stopped",
        ):
            rec.close()
        rec.close()  # idempotent


def test_a_removed_rrd_is_seen(tmp_path, params):
    """The .rrd removed while recording: rerun goes on writing the unlinked file without an
    error; the watch sees the path no longer names the file it opened."""
    from drs_ros.recording.rerun_sink import RerunSinkError

    path = tmp_path / "run.rrd"
    rec = RerunRecorder(path, params)
    rec.log_state(0.0, [0.01, 0.5, 0.6], 1.0)
    path.unlink()
    end = time.monotonic() + 30.0
    while rec.sink_error is None and time.monotonic() < end:
        time.sleep(0.05)
    assert rec.sink_error == f"the file {str(path)!r} was removed while recording"
    with pytest.raises(RerunSinkError, match="was removed while recording"):
        rec.close()


# ---- the sender thread ------------------------------------------------------------------------
def held_send_columns(rec, fail_batch: int | None = None, error: Exception | None = None):
    """Wrap ``rec.rec.send_columns`` (rerun's own, called by the recorder's sender thread): each
    call waits for the returned event; the ``fail_batch``-th batch (0-based, counted by its
    first call, the stroke series) raises ``error`` instead of being sent."""
    import threading

    real = rec.rec.send_columns
    release = threading.Event()
    batches = {"n": -1}

    def send_columns(entity, **kw):
        release.wait()
        if entity == "series/stroke":
            batches["n"] += 1
        if batches["n"] == fail_batch:
            raise error
        return real(entity, **kw)

    rec.rec.send_columns = send_columns
    return release


def verified(path) -> bool:
    from drs_ros.recording.rerun_cli import run_rerun_cli

    return run_rerun_cli(["rrd", "verify", str(path)]).returncode == 0


def test_close_sends_the_partial_batch_and_the_queue_every_state_in_order(tmp_path, params):
    """Twenty-five batches of 8 and a partial one of 3 are logged while the sender is held at
    its first batch (so the queue is full and nothing is sent when close() starts): the .rrd
    then holds every state logged, in order, with the values given (read back with rerun's
    reader; ``rerun rrd verify`` passes), and close() joined the sender thread."""
    import threading

    t, q, _ = manoeuvre_states(params, 203)
    force = np.arange(t.size) * 7.0
    path = tmp_path / "run.rrd"
    before = set(threading.enumerate())
    rec = RerunRecorder(path, params, max_draw_hz=500.0, batch=8)
    ours = set(threading.enumerate()) - before
    release = held_send_columns(rec)
    flags = [rec.log_state(ti, qi, fi) for ti, qi, fi in zip(t, q, force, strict=True)]
    assert rec.sample_count == 0  # nothing sent yet: 25 batches queued, 3 states buffered
    threading.Timer(0.3, release.set).start()
    rec.close()
    assert not any(th.is_alive() for th in ours)  # the sender (and the sink watch) joined
    rec.close()  # idempotent
    assert rec.sample_count == t.size and rec.draw_count == sum(flags)
    t_read, stroke = read_series(path, "/series/stroke")
    np.testing.assert_allclose(t_read, t, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(stroke, q[:, 0])
    np.testing.assert_array_equal(read_series(path, "/series/piston_force")[1], force)
    np.testing.assert_allclose(
        read_series(path, "/series/gap")[1], kinematics.gap(q, params), rtol=0, atol=1e-15
    )
    _, other = read_rows(path)
    assert all(other["/" + e] == sum(flags) for e in DRAWINGS)
    assert verified(path)


@pytest.mark.parametrize("taken", [True, False])
def test_a_batch_the_sender_fails_is_kept_and_logging_neither_raises_nor_waits(
    tmp_path, params, taken
):
    """rerun's send_columns raises (ENOSPC) for the second batch, while the sender is held:
    log_state went on returning meanwhile (no wait, no raise); the failure is kept with its ten
    states (take_send_failures), or, when nobody took it, close() names them. The .rrd holds
    every other state and passes ``rerun rrd verify``."""
    import errno

    t, q, _ = manoeuvre_states(params, 35)
    path = tmp_path / "run.rrd"
    rec = RerunRecorder(path, params, batch=10)
    full = OSError(errno.ENOSPC, "No space left on device")
    release = held_send_columns(rec, fail_batch=1, error=full)
    for ti, qi in zip(t, q, strict=True):
        rec.log_state(ti, qi, 1.0)  # the sender is held: these must neither wait nor raise
    assert not release.is_set() and not rec.send_failed
    release.set()
    if taken:
        rec.flush()
        (failure,) = rec.take_send_failures()
        assert failure.error is full and failure.states == 10
        rec.close()
    else:
        with pytest.raises(
            RerunLogError,
            match=r"lacks 10 states the sender could not send "
            r"\(1 batches; last: OSError: \[Errno 28\] No space left",
        ):
            rec.close()
    t_read, _ = read_series(path, "/series/stroke")
    np.testing.assert_allclose(t_read, np.concatenate([t[:10], t[20:]]), rtol=0, atol=1e-9)
    assert verified(path)


@pytest.mark.parametrize("close_after", [1, 45, 700])
def test_a_close_while_another_thread_logs_loses_no_state(tmp_path, params, close_after):
    """A thread logs states as fast as it can; this one closes the recorder once
    ``close_after`` were logged. Every log_state that returned is in the .rrd, in order, and the
    first one after the close is refused ('is closed'): nothing in between is lost. (A race:
    run it repeated with both cores busy.)"""
    import threading
    import time

    _, q, _ = manoeuvre_states(params, 50)
    path = tmp_path / "run.rrd"
    rec = RerunRecorder(path, params, batch=16)
    returned, refused = [], []

    def log_until_closed():
        k = 0
        while True:
            try:
                rec.log_state(k * 1e-4, q[k % len(q)], float(k))
            except RerunLogError as exc:
                refused.append(str(exc))
                return
            returned.append(k)
            k += 1

    th = threading.Thread(target=log_until_closed)
    th.start()
    end = time.monotonic() + 60.0
    while len(returned) < close_after and time.monotonic() < end:
        time.sleep(1e-4)
    rec.close()
    th.join(timeout=60.0)
    assert not th.is_alive() and len(refused) == 1 and "is closed" in refused[0]
    _, force = read_series(path, "/series/piston_force")
    np.testing.assert_array_equal(force, np.arange(len(returned), dtype=float))
    assert len(returned) >= close_after and rec.sample_count == len(returned)
    assert verified(path)
