"""Shared fixtures. Model tests never import rclpy."""

from __future__ import annotations

import os

import pytest

# Anything that starts rclpy in this process stays on loopback and checks field types.
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_PYTHON_CHECK_FIELDS", "1")

from node_support import ros_context  # noqa: E402, F401 - fixture for the node tests

# Under pytest-xdist each worker keeps the ROS logs of what it starts in a directory of its own.
_WORKER = os.environ.get("PYTEST_XDIST_WORKER")
if _WORKER and os.environ.get("ROS_LOG_DIR"):
    os.environ["ROS_LOG_DIR"] = os.path.join(os.environ["ROS_LOG_DIR"], _WORKER)

from drs_model.errors import NumbaUnavailableError  # noqa: E402
from drs_model.params import DRSParams  # noqa: E402


@pytest.fixture(scope="session")
def params() -> DRSParams:
    return DRSParams()


@pytest.fixture(scope="session", autouse=True)
def _numba_cache():
    """Compile every numba function of drs_model once, before any test (or load them from numba's
    cache, which ``make`` fills): the node tests start node processes, which would each compile
    on a cold cache."""
    try:
        from drs_model.compiled.warm import warm_up
    except NumbaUnavailableError:
        return  # the plain Python kernels run
    warm_up()


@pytest.fixture(scope="session")
def node_bag(tmp_path_factory):
    """A bag the node records now, through the demo's whole scenario (every message type): the
    demo as a process, its node as another, over loopback DDS. Recorded once per run: pytest-xdist
    workers share the first worker's recording (the tests only read it)."""
    import fcntl

    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return _record_node_bag(tmp_path_factory.mktemp("demo"))
    shared = tmp_path_factory.getbasetemp().parent / "node_bag"  # the run's, not the worker's
    shared.mkdir(exist_ok=True)
    with open(shared / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # the others wait for the one recording
        if not (shared / "recorded").exists():
            _record_node_bag(shared / "out")
            (shared / "recorded").touch()
    return shared / "out" / "demo"


def _record_node_bag(out):
    import subprocess
    import sys

    from node_support import domain_for, node_env
    from ros_support import require_rclpy

    require_rclpy()
    out.mkdir(parents=True, exist_ok=True)
    env = node_env(out, domain_for("conftest::node_bag"))
    res = subprocess.run(
        [sys.executable, "-m", "drs_ros.demo", "--out", str(out), "--domain", env["ROS_DOMAIN_ID"]],
        capture_output=True,
        text=True,
        timeout=180,
        env=env,
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    return out / "demo"
