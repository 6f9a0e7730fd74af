"""RerunRecorder: the .rrd reads back with the entities and scalar rows that were logged."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from ros_support import manoeuvre_states, require_module  # noqa: E402

rr = require_module("rerun")

from drs_model.errors import InputError  # noqa: E402
from drs_ros.rerun_log import DRAWINGS, SERIES, RerunLogError, RerunRecorder  # noqa: E402


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
    with pytest.raises(InputError, match="max_draw_hz must be a finite number > 0"):
        RerunRecorder(tmp_path / "x.rrd", params, max_draw_hz=0.0)
    with RerunRecorder(tmp_path / "y.rrd", params) as rec:
        with pytest.raises(InputError, match=r"t must have shape \(n,\) and q \(n, 3\)"):
            rec.log_trajectory([0.0, 1.0], np.zeros((3, 3)))
        with pytest.raises(InputError, match="non-decreasing"):
            rec.log_trajectory([1.0, 0.0], np.zeros((2, 3)))
        with pytest.raises(InputError, match=r"q must hold \[s, psi1, psi3\]"):
            rec.log_state(0.0, [0.0, 0.0])
