"""Run a study on Dask: the design's rows in chunks, one task per chunk
(:func:`drs_model.cluster.map_unordered`), gathered into one table; then the Parquet file, the
figures, the Sobol' indices and a summary.

A chunk is a batch of :func:`.evaluate.evaluate` (vectorised and compiled inside); the chunk size
is fixed by the caller, never by the number of workers, so that every chunk computes the same
arrays whatever the cluster, and a study gives the same numbers, to the bit, on 1 worker or 100.
A chunk whose task fails (a worker lost) gives its rows the task's error: never the end of the run.
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..cluster import TaskFailure, dask_client, map_unordered
from ..errors import InputError
from . import plots
from .design import design as study_design
from .evaluate import RESULT_COLUMNS, TEXT_COLUMNS, evaluate
from .sensitivity import Indices, sobol
from .spec import StudySpec

#: Rows per task unless told: ~0.25 s of work, against ~6-10 ms of Dask per task (measured).
DEFAULT_CHUNK = 128


def evaluate_chunk(values: np.ndarray, *, design, scene, fields) -> dict[str, np.ndarray]:
    """One task: :func:`.evaluate.evaluate` of a chunk of rows (module level: Dask pickles it by
    name)."""
    return evaluate(design, scene, fields, values)


def chunks(n: int, size: int) -> list[tuple[int, int]]:
    """``(start, stop)`` of the chunks of ``n`` rows, ``size`` rows each (the last may be
    shorter)."""
    if isinstance(size, bool) or not isinstance(size, int) or size < 1:
        raise InputError(f"chunk must be a whole number >= 1 of rows, got {size!r}")
    return [(a, min(a + size, n)) for a in range(0, n, size)]


@dataclass
class StudyResult:
    """A study's rows: ``columns`` (name -> array, every row, in design order), the spec, and the
    Sobol' indices of each result (None without sensitivity or with too few complete groups)."""

    spec: StudySpec
    columns: dict[str, np.ndarray]
    indices: dict[str, Indices | None]

    def table(self):
        """The rows as a :class:`pyarrow.Table` (the spec in the schema's metadata)."""
        import pyarrow as pa

        arrays = {}
        for name, col in self.columns.items():
            if col.dtype == object:
                arrays[name] = pa.array(list(col), type=pa.string())
            else:
                arrays[name] = pa.array(col)
        meta = {"drs.study": json.dumps(spec_summary(self.spec))}
        return pa.table(arrays).replace_schema_metadata(meta)


def spec_summary(spec: StudySpec) -> dict:
    """The spec as plain data (for the table's metadata and ``--json``)."""
    return {
        "sampler": spec.sampler,
        "samples": spec.samples,
        "seed": spec.seed,
        "sensitivity": spec.sensitivity,
        "runs": spec.runs,
        "scene": asdict(spec.scene),
        "parameters": {
            name: {"distribution": type(d).__name__.lower(), **asdict(d)}
            for name, d in zip(spec.fields, spec.distributions, strict=True)
        },
        "design": spec.design.to_dict(),
    }


def run_study(
    spec: StudySpec,
    *,
    jobs: int | None = None,
    scheduler: str | None = None,
    chunk: int = DEFAULT_CHUNK,
    progress: bool | None = None,
    client=None,
) -> StudyResult:
    """Evaluate every row of ``spec``'s design on Dask (an embedded cluster of ``jobs`` workers,
    the cluster at ``scheduler``, or an open ``client``) and gather the rows in design order."""
    rows = study_design(spec)
    n = rows.values.shape[0]
    spans = chunks(n, chunk)
    columns: dict[str, np.ndarray] = {
        "sample": np.arange(n, dtype=np.int64),
        "block": rows.block,
    }
    for i, name in enumerate(spec.fields):
        columns[name] = rows.values[:, i]
    for name in RESULT_COLUMNS:
        columns[name] = np.full(n, np.nan)
    for name in TEXT_COLUMNS:
        columns[name] = np.full(n, None, dtype=object)
    items = [rows.values[a:b] for a, b in spans]
    kwargs = {"design": spec.design, "scene": spec.scene, "fields": spec.fields}

    def gather(c):
        for k, got in map_unordered(
            c, evaluate_chunk, items, description="study", progress=progress, **kwargs
        ):
            a, b = spans[k]
            if isinstance(got, TaskFailure):
                columns["error"][a:b] = f"task failed: {got}"
                continue
            for name in (*RESULT_COLUMNS, *TEXT_COLUMNS):
                columns[name][a:b] = got[name]

    if client is not None:
        gather(client)
    else:
        with dask_client(scheduler=scheduler, jobs=jobs) as c:
            gather(c)
    indices: dict[str, Indices | None] = {}
    if spec.sensitivity:
        for name in plots.DISPLAY:
            indices[name] = sobol(columns[name], rows.block, spec.fields)
    return StudyResult(spec, columns, indices)


def write_outputs(result: StudyResult, out_dir: str | Path) -> dict[str, Path]:
    """``study.parquet``, ``histograms.png`` and (with sensitivity) ``sensitivity.png`` in
    ``out_dir`` (created)."""
    import pyarrow.parquet as pq

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"table": out / "study.parquet"}
    pq.write_table(result.table(), paths["table"])
    spec = result.spec
    title = f"drs study: {spec.runs} runs ({spec.sampler}, seed {spec.seed})"
    paths["histograms"] = plots.histograms(result.columns, out / "histograms.png", title)
    if any(v is not None for v in result.indices.values()):
        paths["sensitivity"] = plots.sensitivity(
            result.indices, spec.fields, out / "sensitivity.png", "Sobol' indices: " + title
        )
    return paths


def summary(result: StudyResult) -> dict:
    """Counts, each result's spread (mean, std, min, 1 %, 50 %, 99 %, max) and ranking."""
    cols = result.columns
    errors = [e for e in cols["error"] if e is not None]
    reasons: dict[str, int] = {}
    for e in errors:  # grouped by their words: the numbers differ from sample to sample
        head = re.sub(r"-?\d[\d.e+-]*", "#", e)
        reasons[head] = reasons.get(head, 0) + 1
    spread = {}
    for name in RESULT_COLUMNS:
        x = cols[name][np.isfinite(cols[name])]
        if x.size == 0:
            spread[name] = None
            continue
        p1, p50, p99 = np.percentile(x, [1, 50, 99])
        spread[name] = {
            "n": int(x.size),
            "mean": float(x.mean()),
            "std": float(x.std()),
            "min": float(x.min()),
            "p1": float(p1),
            "p50": float(p50),
            "p99": float(p99),
            "max": float(x.max()),
        }
    ranking = {}
    for name, ind in result.indices.items():
        if ind is None:
            continue
        order = np.argsort(-ind.total_order)
        ranking[name] = [
            {
                "field": result.spec.fields[i],
                "first_order": float(ind.first_order[i]),
                "total_order": float(ind.total_order[i]),
            }
            for i in order
        ]
    status = {}
    for name in ("opening_status", "closing_status"):
        counts: dict[str, int] = {}
        for v in cols[name]:
            if v is not None:
                counts[v] = counts.get(v, 0) + 1
        status[name] = counts
    return {
        "runs": int(cols["sample"].size),
        "failed": len(errors),
        "reasons": reasons,
        "results": spread,
        "forward_runs": status,
        "sensitivity": ranking,
    }
