"""Many independent runs on Dask: the one place drs opens a ``dask.distributed`` client.

Work that outgrows one process (a season of bags, a tolerance study) goes through
:func:`dask_client` and :func:`map_unordered`:

* no ``scheduler`` address: an embedded :class:`distributed.LocalCluster` of ``jobs`` worker
  processes with one thread each (the runs hold the GIL: numpy on small arrays, numba, Python),
  closed when the ``with`` block ends;
* ``scheduler="tcp://host:8786"``: an existing cluster (``dask scheduler`` / ``dask worker``),
  which is left running.

Nothing here schedules: Dask does. :func:`map_unordered` only submits one task per item, yields
each result as it completes (with a progress bar on a terminal) and turns a task's exception into
a :class:`TaskFailure` value, so that one bad item never ends a run of thousands.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from .errors import DaskUnavailableError, InputError, SchedulerUnreachableError

#: Seconds to wait for an existing scheduler before :class:`SchedulerUnreachableError` (default).
CONNECT_TIMEOUT_S = 10.0


def _distributed():
    try:
        import distributed
    except ImportError as exc:  # pragma: no cover - the fleet extra is part of every install
        raise DaskUnavailableError(
            "many runs at once need dask.distributed: pip install 'drs[fleet]'"
        ) from exc
    return distributed


def default_jobs() -> int:
    """Worker processes of an embedded cluster when ``jobs`` is not given: the usable cores."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


@contextmanager
def dask_client(
    scheduler: str | None = None,
    jobs: int | None = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
) -> Iterator[Any]:
    """A ``distributed.Client``: on the cluster at ``scheduler``, or on an embedded
    ``LocalCluster`` of ``jobs`` single-threaded worker processes (default: the usable cores).

    ``jobs`` is refused with an existing cluster (its workers are whatever it has)."""
    distributed = _distributed()
    if scheduler is not None:
        if jobs is not None:
            raise InputError(
                f"jobs={jobs} applies to the embedded cluster only; the cluster at {scheduler!r} "
                "runs on the workers it has"
            )
        try:
            client = distributed.Client(scheduler, timeout=connect_timeout_s)
        except (OSError, TimeoutError) as exc:
            raise SchedulerUnreachableError(
                f"no Dask scheduler answered at {scheduler!r} within {connect_timeout_s:g} s "
                f"({type(exc).__name__}: {exc})"
            ) from exc
        with client:
            yield client
        return
    n = default_jobs() if jobs is None else jobs
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise InputError(f"jobs must be a whole number >= 1, got {jobs!r}")
    # processes: each run holds the GIL. Loopback only; no dashboard, and the scheduler's HTTP
    # server (its health routes, started even without a dashboard) on a free port rather than
    # 8787, which a second cluster on the machine would find taken
    with (
        distributed.LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            scheduler_kwargs={"dashboard_address": ":0"},
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


@dataclass(frozen=True)
class TaskFailure:
    """What a task raised, as a value: the item's index, the exception type's name and message."""

    index: int
    error_type: str
    message: str

    def __str__(self) -> str:
        return f"{self.error_type}: {self.message}"


def map_unordered(
    client: Any,
    function: Callable[..., Any],
    items: Iterable[Any],
    *,
    description: str = "tasks",
    progress: bool | None = None,
    **kwargs: Any,
) -> Iterator[tuple[int, Any]]:
    """Run ``function(item, **kwargs)`` on the cluster, one task per item; yield
    ``(index, result)`` as tasks complete, ``result`` a :class:`TaskFailure` for a task that
    raised. ``progress`` (default: when stderr is a terminal) draws a tqdm bar."""
    distributed = _distributed()
    items = list(items)
    # pure=False: two equal items (a bag listed twice) are two runs, as asked
    futures = client.map(function, items, pure=False, **kwargs)
    index_of = {future.key: i for i, future in enumerate(futures)}
    show = sys.stderr.isatty() if progress is None else progress
    bar = None
    if show:
        from tqdm import tqdm

        bar = tqdm(total=len(futures), desc=description, unit="task", file=sys.stderr)
    try:
        for future in distributed.as_completed(futures):
            i = index_of[future.key]
            if future.status == "error":
                exc = future.exception()
                result: Any = TaskFailure(i, type(exc).__name__, str(exc))
            else:
                result = future.result()
            future.release()  # the result is ours now: free the worker's memory
            if bar is not None:
                bar.update(1)
            yield i, result
    finally:
        if bar is not None:
            bar.close()
        client.cancel(futures)
