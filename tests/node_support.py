"""Fixtures for node tests: one rclpy context and one DDS domain per test, spinning helpers."""

from __future__ import annotations

import contextlib
import os
import subprocess
import time
import zlib
from collections.abc import Callable, Iterator, Sequence

import pytest
from ros_support import require_rclpy

from drs_ros.node.command_line import PYTHON_M_DRS_ROS, node_command


def domain_for(nodeid: str) -> int:
    """A domain id derived from the test id (tests never hear each other).

    ``DRS_TEST_DOMAIN_BASE`` (default 1) and ``DRS_TEST_DOMAIN_SPAN`` (default 100) choose the
    range ``base .. base + span - 1``, so that two checkouts testing at once stay apart. Under
    pytest-xdist each worker takes its own equal share of that range, so that the tests two
    workers run at the same moment stay apart too."""
    base = int(os.environ.get("DRS_TEST_DOMAIN_BASE", "1"))
    span = int(os.environ.get("DRS_TEST_DOMAIN_SPAN", "100"))
    worker, workers = xdist_worker()
    share = max(span // workers, 1)
    return base + (worker * share) % span + zlib.crc32(nodeid.encode()) % share


def xdist_worker() -> tuple[int, int]:
    """``(index, count)`` of this pytest-xdist worker (``gw0`` is 0), ``(0, 1)`` outside xdist."""
    name = os.environ.get("PYTEST_XDIST_WORKER", "")
    if not name.startswith("gw"):
        return 0, 1
    return int(name[2:]), max(int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")), 1)


@pytest.fixture
def ros_context(request, tmp_path, monkeypatch):
    rclpy = require_rclpy()
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_PYTHON_CHECK_FIELDS", "1")
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path / "ros-log"))
    from rclpy.context import Context

    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain_for(request.node.nodeid))
    yield ctx
    rclpy.try_shutdown(context=ctx)


@contextlib.contextmanager
def node_with_client(
    domain: int, overrides: Sequence, client_name: str, before_node: Callable | None = None
) -> Iterator[tuple]:
    """A :class:`~drs_ros.node.DRSNode` with ``overrides`` (rclpy Parameters) and a client node
    ``client_name`` in one new rclpy context on ``domain``, spun by one executor: yields
    ``(node, client, executor)``. ``before_node(client)`` runs before the node exists (a
    subscriber ``fidelity: auto`` must see). At the end the node's recordings are finished, then
    the executor, both nodes and the context are shut down."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from drs_ros.node import DRSNode

    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    client = rclpy.create_node(client_name, context=ctx)
    node = ex = None
    try:
        if before_node is not None:
            before_node(client)
        node = DRSNode(context=ctx, parameter_overrides=list(overrides))
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        ex.add_node(client)
        yield node, client, ex
    finally:
        if node is not None:
            node.close_recordings()
        if ex is not None:
            ex.shutdown()
        client.destroy_node()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=ctx)


class NodeAndClient:
    """A :class:`~drs_ros.node.DRSNode` with ``overrides`` (rclpy Parameters) and a client node
    ``client_name`` in the context ``ctx``, spun by one executor (``exec``). :meth:`close`
    finishes the node's recordings, then shuts down the executor and both nodes."""

    def __init__(self, ctx, overrides: Sequence, client_name: str) -> None:
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node

        from drs_ros.node import DRSNode

        self.node = DRSNode(context=ctx, parameter_overrides=list(overrides))
        self.client = Node(client_name, context=ctx)
        self.exec = SingleThreadedExecutor(context=ctx)
        self.exec.add_node(self.node)
        self.exec.add_node(self.client)

    def close(self) -> None:
        self.node.close_recordings()
        self.exec.shutdown()
        self.client.destroy_node()
        self.node.destroy_node()


@contextlib.contextmanager
def hydraulic_node_in(out, fixture: str, client_name: str) -> Iterator[tuple]:
    """:func:`node_with_client` for a module-scoped fixture (which has no ``monkeypatch``): a
    hydraulic node recording into ``out/bag``, DDS on loopback and the ROS log in
    ``out/ros-log`` while it runs, on the domain of ``fixture`` (its name, as a test id)."""
    from rclpy.parameter import Parameter

    overrides = [
        Parameter("fidelity", value="hydraulic"),
        Parameter("bag_path", value=str(out / "bag")),
    ]
    mp = pytest.MonkeyPatch()
    mp.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    mp.setenv("ROS_LOG_DIR", str(out / "ros-log"))
    try:
        with node_with_client(domain_for(fixture), overrides, client_name) as parts:
            yield parts
    finally:
        mp.undo()


def spin_until(executor, predicate: Callable[[], bool], timeout: float = 5.0) -> bool:
    """Spin ``executor`` until ``predicate()`` or ``timeout`` [s] of wall time."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.01)
        if predicate():
            return True
    return predicate()


def call_answered(executor, client, request, timeout: float):
    """The answer of an idempotent service call (``~/drs``: opening twice is opening), sent
    again each ``drs_ros.client.RESEND_S`` unanswered, as ``DRSClient.call_drs`` does: a node
    process that took the request before it had discovered this client's reply reader answers
    into the void (a service is two topics discovered apart; rcl#1048). None after ``timeout``
    [s] of wall time."""
    from drs_ros.client import RESEND_S

    end = time.monotonic() + timeout
    while True:
        fut = client.call_async(request)
        if spin_until(executor, fut.done, min(RESEND_S, max(end - time.monotonic(), 0.0))):
            return fut.result()
        client.remove_pending_request(fut)
        if time.monotonic() >= end:
            return None


def spin_for(executor, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.005)


def node_env(tmp_path, domain: int) -> dict[str, str]:
    """Environment for a node subprocess: the whole parent environment (the ROS wheels re-exec
    with LD_LIBRARY_PATH) plus loopback-only DDS and our domain."""
    env = dict(os.environ)
    env.update(
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_DOMAIN_ID=str(domain),
        ROS_LOG_DIR=str(tmp_path / "ros-log"),
        ROS_PYTHON_CHECK_FIELDS="1",
        PYTHONUNBUFFERED="1",
    )
    return env


def start_node(
    tmp_path, domain: int, *params: str, stdout=subprocess.PIPE, argv: list[str] | None = None
) -> subprocess.Popen:
    """The node as its own process (``python -m drs_ros``, or ``argv``) on ``domain`` with
    ``-p`` for each of ``params`` (``name:=value``); its output (stdout and stderr) in ``stdout``
    as text."""
    require_rclpy()
    args = node_command(
        ros_args=[item for p in params for item in ("-p", p)], program=argv or PYTHON_M_DRS_ROS
    )
    return subprocess.Popen(
        args, env=node_env(tmp_path, domain), stdout=stdout, stderr=subprocess.STDOUT, text=True
    )


def wait_for_file_growth(path, timeout: float = 20.0, min_size: int = 1) -> bool:
    """Wait until ``path`` holds at least ``min_size`` bytes, for ``timeout`` [s] of wall time."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if path.exists() and path.stat().st_size >= min_size:
            return True
        time.sleep(0.1)
    return False
