"""The bag tools read a bag in bounded memory: checking a bag four times as long takes no more
memory (traced Python and numpy allocations, tracemalloc). Keeping the decoded messages, as the
check did before, grows by about three times the file's growth (measured: 7.3 -> 19.3 MB for a
1 -> 3.9 MB bag)."""

from __future__ import annotations

import contextlib
import gc
import io
import tracemalloc

import pytest
from ros_support import require_rclpy

pytestmark = pytest.mark.ros

#: Manoeuvres (50 joint states each) of the shorter bag (~1.2 MB); the longer one has 4x.
CYCLES = 60
#: Chunk size of both bags [bytes]: the shorter one already has several full chunks, so both
#: reach the same steady state (reading one chunk while the one before is still referenced).
#: With 1 MiB chunks the shorter bag had one full chunk and the peaks differed by ~0.5 MB of
#: chunk bytes, not of growth (once by 2.2 MB, when the shorter check peaked lower).
CHUNK_BYTES = 256 * 1024


def _traced_peak(fn) -> tuple[object, int]:
    """``fn()``'s result and the peak of traced allocations [bytes] while it ran."""
    gc.collect()
    tracemalloc.start()
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            result = fn()
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _size(bag) -> int:
    return sum(f.stat().st_size for f in bag.iterdir())


def test_check_memory_does_not_grow_with_the_bag(tmp_path, monkeypatch):
    require_rclpy()
    from long_bag_support import write_long_bag

    from drs_ros.bag.check import command as check
    from drs_ros.bag.check import model_checks

    # blocks of 1000 joint states: the shorter bag already spans 5 of them
    monkeypatch.setattr(model_checks, "BLOCK_STATES", 1000)
    short = write_long_bag(tmp_path / "short", CYCLES, chunk_size=CHUNK_BYTES)
    long = write_long_bag(tmp_path / "long", 4 * CYCLES, chunk_size=CHUNK_BYTES)
    growth_bytes = _size(long) - _size(short)
    check.main([str(short)])  # imports and caches outside the measurement
    status_short, peak_short = _traced_peak(lambda: check.main([str(short)]))
    status_long, peak_long = _traced_peak(lambda: check.main([str(long)]))
    assert status_short == status_long == check.EXIT_OK
    print(f"peak {peak_short} -> {peak_long} bytes for {_size(short)} -> {_size(long)} bytes")
    # the check's peak grows by less than a quarter of the file's growth (measured: ~0.1, the
    # garbage collector's timing); keeping the decoded messages grows by ~3x the file's growth
    assert peak_long - peak_short < 0.25 * growth_bytes, (peak_short, peak_long, growth_bytes)
