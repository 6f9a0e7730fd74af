"""``drs-demo`` (``make demo``): the node through a DRS cycle over DDS, recorded and checked.

1. starts ``drs-node`` as a process (loopback-only DDS, its own domain) recording
   ``bags/demo/`` (MCAP + metadata.yaml) and ``bags/demo.rrd``;
2. drives it from a second node: open, hold, close through the ``~/drs`` service; a stroke
   command; a trajectory; a FollowJointTrajectory goal; a force step; one bad command (NaN,
   refused with a reason);
3. stops it with SIGINT (it finishes both recordings and exits 0);
4. runs ``drs-check`` on the bag, reads the ``.rrd`` back, and prints a short summary.

``--name`` must be a plain name (no path separator, not ``.`` or ``..``, no leading ``-``). A
previous run's ``OUT/NAME/`` and ``OUT/NAME.rrd`` are replaced only if they are what a run makes
(a bag directory holding only ``metadata.yaml`` and ``.mcap`` files; a regular ``.rrd`` file);
anything else there is left alone and the demo refuses to start (exit status 2, one line).
"""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import threading
from pathlib import Path

from drs_model.cli._common import output_path
from drs_model.cli.exit_status import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from drs_model.cli.start_signals import (
    end_signals,
    exit_at_once_on_signal,
    ignore_signals,
    interrupt_on_signal,
    signal_received,
)
from drs_model.cli.strict_parser import StrictParser
from drs_ros.errors import DRSRosError
from drs_ros.node.command_line import node_command


class DemoError(DRSRosError, ValueError):
    """The demo's arguments would name or replace something the demo did not make."""


def check_name(name: str) -> str:
    """``name`` if it is a plain file name (``OUT/NAME`` stays inside ``OUT``), else
    :class:`DemoError`."""
    if (
        not name
        or name in (".", "..")
        or "/" in name
        or (os.altsep and os.altsep in name)
        or os.sep in name
        or "\0" in name
        or name.startswith("-")
    ):
        raise DemoError(
            f"--name must be a plain name (no path separator, not '.' or '..', not empty, no "
            f"leading '-'), got {name!r}"
        )
    return name


def remove_previous_run(bag: Path, rrd: Path) -> None:
    """Delete a previous run's bag directory and ``.rrd``, and nothing else.

    ``bag`` is removed only if it is a directory (not a link) holding nothing but
    ``metadata.yaml`` and ``*.mcap`` regular files; ``rrd`` only if it is a regular file named
    ``*.rrd``. Anything else raises :class:`DemoError` before anything is deleted.
    """
    bag_files: list[Path] = []
    if os.path.lexists(bag):
        mode = bag.lstat().st_mode
        if not stat.S_ISDIR(mode):
            raise DemoError(f"{str(bag)!r} exists and is not a bag directory: not replacing it")
        for entry in bag.iterdir():
            is_bag_file = entry.name == "metadata.yaml" or entry.suffix == ".mcap"
            if not (is_bag_file and stat.S_ISREG(entry.lstat().st_mode)):
                raise DemoError(
                    f"{str(bag)!r} holds {entry.name!r}, which a drs bag does not: not a bag "
                    "directory a demo made, not replacing it"
                )
            bag_files.append(entry)
    if os.path.lexists(rrd) and not (rrd.suffix == ".rrd" and stat.S_ISREG(rrd.lstat().st_mode)):
        raise DemoError(f"{str(rrd)!r} exists and is not a regular .rrd file: not replacing it")
    for entry in bag_files:
        entry.unlink()
    if bag_files or os.path.lexists(bag):
        bag.rmdir()
    rrd.unlink(missing_ok=True)


def _env(domain: int, log_dir: Path) -> dict[str, str]:
    env = dict(os.environ)  # the ROS wheels re-exec with LD_LIBRARY_PATH: keep everything
    env.update(
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_DOMAIN_ID=str(domain),
        ROS_LOG_DIR=str(log_dir),
        PYTHONUNBUFFERED="1",
    )
    return env


def _say(text: str) -> None:
    print(f"[demo] {text}", flush=True)


def drive(domain: int, timeout: float = 30.0) -> dict[str, object]:
    """Run the scripted scenario against a running node through the product's client
    (:class:`drs_ros.client.DRSClient`); returns what the client observed."""
    from sensor_msgs.msg import JointState

    from drs_ros.client import DRSClient

    with DRSClient(domain, timeout=timeout) as client:
        # the node computes its reactions only while someone listens: listen, so the bag holds them
        client.listen(JointState, "/drs/joint_reactions")
        client.wait_ready()
        client.spin(0.2)
        _say(f"open   -> {client.call_drs(True)}")
        client.spin(0.04)  # the seed holds 30 ms after the 10 ms opening
        _say(f"close  -> {client.call_drs(False)}")
        client.spin(0.3)
        _say("stroke -> 0.020 m")
        client.stroke(0.020)
        client.spin(0.3)
        _say("traj   -> 30 mm at 20 ms, 10 mm at 40 ms, 25 mm at 60 ms (JointTrajectory)")
        client.trajectory([(0.020, 0.030), (0.040, 0.010), (0.060, 0.025)])
        client.spin(0.3)
        _say(f"action -> {client.follow(0.015, 0.05)}")
        client.spin(0.1)
        _say("force  -> 1500 N step (forward dynamics, onto the open stop)")
        client.force(1500.0)
        client.spin(0.3)
        _say("force  -> 0 N (the air load closes the flap onto its stop)")
        client.force(0.0)
        client.spin(0.3)
        _say("bad    -> stroke NaN (must be refused, node keeps running)")
        client.stroke(float("nan"))
        client.spin(1.5)  # let a diagnostics message report the refusal
        return client.seen


def _rrd_scalar_rows(path: Path) -> int:
    """Scalar rows in an .rrd, read back with rerun's own chunk reader (0 if unreadable)."""
    try:
        from rerun.chunk import RrdReader

        rows = 0
        for chunk in RrdReader(str(path)).stream().to_chunks():
            batch = chunk.to_record_batch()
            if any(n.startswith("Scalars:scalars") for n in batch.schema.names):
                rows += batch.num_rows
        return rows
    except Exception as exc:  # noqa: BLE001 - reported, and the demo fails on 0 rows
        _say(f"cannot read {path}: {exc}")
        return 0


def _rrd_verify(path: Path) -> int:
    """``rerun rrd verify`` (the CLI installed with the SDK): an independent read of every chunk."""
    from drs_ros.recording.rerun_cli import run_rerun_cli

    try:
        res = run_rerun_cli(["rrd", "verify", str(path)])
    except (OSError, subprocess.SubprocessError) as exc:
        _say(f"rerun rrd verify could not run: {exc}")
        return 1
    if res.returncode != 0:
        _say(f"rerun rrd verify {path}: {(res.stderr or res.stdout).strip()[-500:]}")
    return res.returncode


def main(argv: list[str] | None = None) -> int:
    """``drs-demo``; the exit status. A SIGINT or SIGTERM ends it with status 0 and one line:
    at once while it starts, then with the node stopped (its recordings finished)."""
    main_thread = threading.current_thread() is threading.main_thread()
    previous = exit_at_once_on_signal("drs-demo") if main_thread else {}
    try:
        return _demo(argv, bool(previous))
    finally:
        end_signals(previous, console_script=argv is None)


def _demo(argv: list[str] | None, signals: bool) -> int:
    ap = StrictParser(prog="drs-demo", description=__doc__.splitlines()[0])
    ap.add_argument(
        "--out",
        default="bags",
        type=output_path,
        help="output folder (default bags/; its parent must exist)",
    )
    ap.add_argument("--domain", type=int, default=int(os.environ.get("DRS_DEMO_DOMAIN", "73")))
    ap.add_argument("--publish-rate", type=float, default=500.0, help="node publish rate [Hz]")
    ap.add_argument("--name", default="demo", help="bag name: OUT/NAME/ and OUT/NAME.rrd")
    args = ap.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    out = Path(args.out)
    try:
        name = check_name(args.name)
        bag, rrd, log_dir = out / name, out / f"{name}.rrd", out / ".ros-log"
        remove_previous_run(bag, rrd)
        out.mkdir(parents=True, exist_ok=True)
    except (DemoError, OSError) as exc:
        print(f"drs-demo: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    env = _env(args.domain, log_dir)
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_LOG_DIR")})
    cmd = node_command(
        {
            "bag_path": bag,
            "rrd_path": rrd,
            "publish_rate_hz": args.publish_rate,
            "flush_period": 0.2,
        }
    )
    _say("starting drs-node: " + " ".join(cmd[1:]))
    if signals:
        interrupt_on_signal()
    node = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    try:
        return _drive_and_check(node, args.domain, bag, rrd)
    except KeyboardInterrupt:
        pass
    except Exception:
        if not signal_received():
            raise
    return _stopped(node)


def _stopped(node: subprocess.Popen) -> int:
    """A SIGINT or SIGTERM stopped the demo: the node is stopped with SIGINT (it finishes its
    recordings), one line, status 0."""
    ignore_signals()  # a second Ctrl-C must not leave the node running
    if node.poll() is None:
        node.send_signal(signal.SIGINT)
    try:
        node.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        node.kill()
        node.communicate()
    print(
        f"drs-demo: stopped by {signal_received() or 'a signal'}; drs-node stopped with exit "
        f"code {node.returncode}",
        file=sys.stderr,
    )
    return EXIT_OK


def _drive_and_check(node: subprocess.Popen, domain: int, bag: Path, rrd: Path) -> int:
    """Drive the started node, stop it, check its bag and recording; the exit status."""
    try:
        seen = drive(domain)
    except Exception as exc:  # noqa: BLE001 - stop the node, then report
        if signal_received():
            raise KeyboardInterrupt from exc
        node.send_signal(signal.SIGINT)
        out_text, _ = node.communicate(timeout=20)
        print(out_text)
        _say(f"FAILED driving the node: {exc}")
        return EXIT_FAILED
    node.send_signal(signal.SIGINT)
    try:
        node_out, _ = node.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        node.kill()
        node_out, _ = node.communicate()
    _say(f"node stopped with SIGINT, exit code {node.returncode}")
    refusals = [line for line in node_out.splitlines() if "refused" in line]
    for line in refusals[:3]:
        _say(f"node log: {line.strip()}")

    from drs_ros.bag.check.command import main as check_main

    _say(f"drs-bag check {bag}")
    rc_check = check_main([str(bag)])
    rc_verify = _rrd_verify(rrd)
    rows = _rrd_scalar_rows(rrd)
    diag = seen.get("diag") or {}
    _say("summary:")
    print(f"  joint states received by the driver : {seen['joint_states']}")
    print(f"  largest gap seen                    : {1e3 * float(seen['gap_max']):.3f} mm")
    print(f"  largest |piston force| seen         : {float(seen['force_max']):.1f} N")
    print(f"  refused commands (diagnostics)      : {diag.get('refused_commands', '?')}")
    print(f"  missed deadlines (diagnostics)      : {diag.get('missed_deadlines', '?')}")
    print(
        f"  bag                                 : {bag} "
        f"({'metadata.yaml ok' if (bag / 'metadata.yaml').exists() else 'NO metadata.yaml'})"
    )
    print(f"  rerun recording                     : {rrd} ({rows} scalar rows)")
    print(f"  rerun rrd verify                    : {'ok' if rc_verify == 0 else 'FAILED'}")
    print(f"  drs-bag check                       : {'PASS' if rc_check == 0 else 'FAIL'}")
    ok = node.returncode == 0 and rc_check == 0 and rc_verify == 0 and rows > 0 and refusals
    return EXIT_OK if ok else EXIT_FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
