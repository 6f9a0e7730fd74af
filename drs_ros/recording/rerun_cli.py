"""The rerun command line installed with the SDK (``rerun rrd verify``...), run with its usage
analytics off: an independent check of the ``.rrd`` files the rerun recorder writes."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path


def run_rerun_cli(args: list[str], timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run the rerun CLI installed with the SDK (e.g. ``["rrd", "verify", path]``) with its
    usage analytics off: a private config directory in which ``rerun analytics disable`` ran, so
    that nothing leaves this machine and the user's own rerun configuration is untouched."""
    exe = Path(sys.executable).with_name("rerun")
    cli = str(exe) if exe.exists() else "rerun"
    with tempfile.TemporaryDirectory(prefix="drs-rerun-") as home:
        env = dict(
            os.environ,
            XDG_CONFIG_HOME=str(Path(home) / "config"),
            XDG_DATA_HOME=str(Path(home) / "data"),
        )
        subprocess.run(
            [cli, "analytics", "disable"], env=env, capture_output=True, timeout=timeout, check=True
        )
        return subprocess.run(
            [cli, *args], env=env, capture_output=True, text=True, timeout=timeout
        )


__all__ = ["run_rerun_cli"]
