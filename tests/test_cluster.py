"""drs_model.cluster on a real embedded Dask cluster (no mocks)."""

from __future__ import annotations

import os
import socket

import pytest

from drs_model.cluster import TaskFailure, dask_client, map_unordered
from drs_model.errors import InputError, SchedulerUnreachableError


def _pid_and_square(x: int) -> tuple[int, int]:
    if x == 3:
        raise ValueError(f"item {x} is bad on purpose")
    return os.getpid(), x * x


def test_two_workers_run_every_item_once_and_a_failure_is_a_value():
    with dask_client(jobs=2) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        got = dict(map_unordered(client, _pid_and_square, range(8), progress=False))
    assert sorted(got) == list(range(8))
    failure = got.pop(3)
    assert isinstance(failure, TaskFailure)
    assert (failure.index, failure.error_type) == (3, "ValueError")
    assert "item 3 is bad on purpose" in failure.message
    assert {i: sq for i, (_, sq) in got.items()} == {i: i * i for i in got}
    # the work ran in worker processes, not here
    assert os.getpid() not in {pid for pid, _ in got.values()}


def test_equal_items_are_separate_runs():
    with dask_client(jobs=1) as client:
        got = sorted(map_unordered(client, _pid_and_square, [2, 2, 2], progress=False))
    assert [i for i, _ in got] == [0, 1, 2]


@pytest.mark.parametrize("jobs", [0, -1, 1.5, True])
def test_bad_jobs_are_refused_with_the_value(jobs):
    with pytest.raises(InputError, match=f"got {jobs!r}"), dask_client(jobs=jobs):
        pass


def test_jobs_with_an_existing_cluster_is_refused():
    with (
        pytest.raises(InputError, match="embedded cluster only"),
        dask_client(scheduler="tcp://127.0.0.1:8786", jobs=2),
    ):
        pass


def test_an_address_nobody_answers_names_it():
    with socket.socket() as s:  # a port that was free a moment ago: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    with (
        pytest.raises(SchedulerUnreachableError, match=address),
        dask_client(scheduler=address, connect_timeout_s=1.0),
    ):
        pass


def test_an_existing_cluster_by_address_is_used_and_left_running():
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None) as cluster:
        with dask_client(scheduler=cluster.scheduler_address) as client:
            got = dict(map_unordered(client, _pid_and_square, [4], progress=False))
        assert got[0][1] == 16
        assert cluster.status.name == "running"


def test_progress_bar_counts_every_task(capfd):
    with dask_client(jobs=1) as client:
        list(
            map_unordered(
                client, _pid_and_square, [1, 2, 3, 4], description="squares", progress=True
            )
        )
    err = capfd.readouterr().err
    assert "squares" in err and "4/4" in err


def test_two_embedded_clusters_at_once_take_no_fixed_port(recwarn):
    with dask_client(jobs=1) as a, dask_client(jobs=1) as b:
        addresses = {a.scheduler_info()["address"], b.scheduler_info()["address"]}
    assert len(addresses) == 2 and all(x.startswith("tcp://127.0.0.1:") for x in addresses)
    said = [str(w.message) for w in recwarn if "already in use" in str(w.message)]
    assert not said, said
