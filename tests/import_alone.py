"""``python import_alone.py``: import each module named on stdin, one per line, in a process of
its own where no module of drs was imported before; one JSON line per name on stdout:
``{"name", "status", "error"}`` (status 0: it imported; ``error``: the child's traceback).

Each child is a fork of this process, taken after it imported the third-party packages of
:data:`PRELOADED` (numpy, scipy, rclpy, ...), which almost every module of drs imports anyway and
which cost ~0.3 s of an interpreter's start each time. What the test asks of a module of drs
(it imports first, alone: no import cycle between modules of drs that only one order of imports
survives, no name it uses at import time without importing it) does not depend on them; the
modules of drs themselves are imported fresh in every child. A child that has not finished after
:data:`TIMEOUT_S` is ended by SIGALRM (status -14).
"""

from __future__ import annotations

import importlib
import json
import os
import signal
import sys
import traceback

#: Third-party modules imported once, before the children fork (those the product imports).
PRELOADED = (
    "numpy",
    "scipy.integrate",
    "scipy.linalg",
    "scipy.optimize",
    "scipy.signal",
    "scipy.special",
    "scipy.stats",
    "yaml",
    "numba",
    "mcap.reader",
    "mcap.writer",
    "mcap.records",
    "rclpy.node",
    "rclpy.action",
    "rclpy.executors",
    "rclpy.lifecycle",
    "rclpy.qos",
    "rclpy.serialization",
    "std_msgs.msg",
    "sensor_msgs.msg",
    "diagnostic_msgs.msg",
    "geometry_msgs.msg",
)
#: Longest one child may take to import its module [s].
TIMEOUT_S = 120


def _preload() -> None:
    """Import what of :data:`PRELOADED` is installed (a missing one is the test's business: the
    child then imports, and fails, as a fresh interpreter would)."""
    for name in PRELOADED:
        try:
            importlib.import_module(name)
        except ImportError:
            pass


def _import_in_child(name: str) -> dict:
    """Fork, import ``name`` in the child, and return its line."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: import, report a traceback through the pipe, never return
        os.close(read_end)
        signal.alarm(TIMEOUT_S)
        try:
            importlib.import_module(name)
        except BaseException:  # noqa: BLE001 - everything the import raised is the report
            os.write(write_end, traceback.format_exc().encode())
            os._exit(1)
        os._exit(0)
    os.close(write_end)
    chunks = []
    while chunk := os.read(read_end, 1 << 16):
        chunks.append(chunk)
    os.close(read_end)
    _, wait_status = os.waitpid(pid, 0)
    status = os.waitstatus_to_exitcode(wait_status)
    return {"name": name, "status": status, "error": b"".join(chunks).decode(errors="replace")}


def main() -> int:
    _preload()
    loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("drs_model", "drs_ros"))
    sys.stdout.write(json.dumps({"ready": True, "drs_modules_loaded": loaded}) + "\n")
    sys.stdout.flush()
    for line in sys.stdin:
        if name := line.strip():
            sys.stdout.write(json.dumps(_import_in_child(name)) + "\n")
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
