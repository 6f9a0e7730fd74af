"""How ``drs-node`` runs: ``main`` (the console script), the stop a signal asks for
(:class:`StopRequest`), and the two ways of driving the node: the deadline loop (ticks at absolute
deadlines in the main thread, an executor thread for the rest) or one executor for everything.
"""

from __future__ import annotations

import atexit
import gc
import os
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from drs_model.cli.exit_status import EXIT_FAILED, EXIT_INTERNAL, EXIT_OK, EXIT_REFUSED
from drs_model.errors import DRSError

from ..errors import DRSRosError
from ..recording.cdr_received import without_source_location
from ..stop_request import StopRequest
from ..threads import NamedThread
from ..timestamps import ns_from_seconds, seconds_from_ns
from .adapter import DRSNode
from .managed import ManagedDRSNode
from .parameters import usage_text
from .tick_gate import TickGate
from .tick_schedule import TickPolicy, apply_tick_policy, leave_tick_policy

RCLError = _rclpy.RCLError

#: How often [s] a thread holding the GIL offers it to the others (see main). The tick waits
#: up to this long for the GIL when it wakes while the executor, the bag's flush thread or the
#: rerun sender runs Python: at 1 kHz, 0.5 ms gave 1.5 % missed deadlines and a lateness p99
#: of 0.6 ms, 0.2 ms 0.5 % and 0.34 ms, 0.1 ms no better for 1 point more of a core
#: (benchmarks/node_rate.py, docs/ros.md).
GIL_SWITCH_INTERVAL_S = 0.0002


#: The longest a loop waits before it looks at the stop flag again [s].
STOP_POLL_S = 0.05


#: The longest the deadline loop's executor thread waits for work [s]: it needs no poll to see a
#: stop (the loop ends its wait, :func:`end_idle_wait`), and each idle wake of the EventsExecutor
#: costs ~130 us of CPU: polled every 50 ms, a quarter of a point of a core. The bound is a
#: safety net only.
EXECUTOR_IDLE_WAIT_S = 1.0


def spin_until_stopped(
    node: Node,
    executor,
    stop: StopRequest,
    tick_gate: TickGate | None = None,
    idle_wait_s: float = STOP_POLL_S,
) -> None:
    """Run ``executor``'s callbacks until ``stop`` is requested or the context ends. A callback
    that raises is logged and counted, and the executor goes on: nothing a participant sends
    (a message the middleware cannot take, say) ends the node's service of the others.

    ``idle_wait_s``: the longest one ``spin_once`` waits for work [s], so the longest before a
    stop is seen unless whoever stops ends the wait (:func:`end_idle_wait`).

    ``tick_gate``: the deadline loop's :class:`~drs_ros.node.tick_gate.TickGate`; before taking
    each event the executor waits for a running tick to end (a tick that starts meanwhile
    shares the GIL with that one callback only). Why: under a command flood the executor runs
    Python without pause, and every 0.2 ms (the GIL switch interval) it would take the GIL from
    the tick, doubling the tick's time."""
    while not stop.requested and executor.context.ok():
        if tick_gate is not None:
            tick_gate.wait_for_tick_end(STOP_POLL_S)  # the tick is over: one callback's turn
        try:
            executor.spin_once(timeout_sec=idle_wait_s)
        except ExternalShutdownException:
            return
        except Exception as exc:  # noqa: BLE001
            if not executor.context.ok():
                return
            note = getattr(node, "executor_error", None)
            if note is not None:
                note(exc)
            else:
                node.get_logger().error(f"callback failed: {type(exc).__name__}: {exc}")


def end_idle_wait(node: Node) -> None:
    """End the wait of an executor spinning ``node`` in another thread, now: a one-shot timer
    due at once. Why a timer: the EventsExecutor's ``wake()`` does not end a ``spin_once``
    that waits (it waits out its timeout), and it takes no guard condition; a timer added
    meanwhile is an event it serves at once. A node whose context is already shut down needs
    none (the shutdown ends the wait)."""
    if not node.context.ok():
        return
    timer = None

    def once() -> None:
        timer.cancel()

    try:
        timer = node.create_timer(0.0, once)
    except Exception:  # noqa: BLE001 - a context shut down meanwhile: the wait ends anyway
        return


def run_deadline_loop(node: DRSNode, stop: StopRequest, context=None) -> None:
    """Drive ``node`` until ``stop`` is requested: ticks at absolute deadlines of the wall clock
    in this thread, everything else in rclpy's EventsExecutor in a second thread, which is
    joined before this returns. A late tick is counted by the node; the deadlines then resume
    from now, so a stall does not cause a burst of catch-up ticks (the simulation catches up
    within one tick).

    Why: one rclpy timer at 250 Hz in a SingleThreadedExecutor rebuilds its wait set at every
    wake-up, which cost more than the physics, the publishing and the recording together
    (docs/ros.md, "Rate"). The executor thread is the EventsExecutor (rclpy.experimental, C++):
    the SingleThreadedExecutor rebuilds its wait set in Python at every wake, ~650 us of CPU a
    command at 100 Hz, and under a 10 kHz command flood half the ticks missed their deadline,
    against 2.6 % with the EventsExecutor (benchmarks/results/node_rate.md).
    """
    context = context or node.context
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    tick_gate = node.tick_gate  # a tick runs through it: the executor's callbacks wait
    thread = NamedThread(
        target=spin_until_stopped,
        args=(node, executor, stop, tick_gate, EXECUTOR_IDLE_WAIT_S),
        name="drs-executor",
    )
    thread.start()
    gp = node.get_parameter
    policy = TickPolicy("SCHED_OTHER", 0)  # until applied: what the finally gives back
    try:
        # after the executor thread started: SCHED_FIFO (when asked and allowed) and the CPU
        # (tick_cpu) are this thread's only
        policy = apply_tick_policy(
            gp("tick_scheduling").value, gp("tick_fifo_priority").value, gp("tick_cpu").value
        )
        report_tick_policy(node, policy)
        lateness = node.effects.lateness
        period_ns = ns_from_seconds(node.publish_period)
        deadline = time.monotonic_ns()
        while not stop.requested and context.ok():
            deadline += period_ns
            wait = deadline - time.monotonic_ns()
            while wait > 0 and not stop.requested:  # a long period still sees a stop soon
                time.sleep(min(seconds_from_ns(wait), STOP_POLL_S))
                wait = deadline - time.monotonic_ns()
            if stop.requested or not context.ok():
                break
            lateness.add(-wait)
            if wait < -period_ns:  # late by more than a period: the deadlines between are skipped
                lateness.skipped += -wait // period_ns
                deadline = time.monotonic_ns()  # resume from now
            tick_gate.run(node.tick, deadline + period_ns)
    finally:
        tick_gate.stopped()
        leave_tick_policy(policy)  # the loop is real-time; the shutdown is not
        stop()  # the executor thread ends too, whatever ended this loop
        end_idle_wait(node)  # now, not at the end of its idle wait
        thread.join()
        executor.shutdown(timeout_sec=1.0)


def warn_tick_cpu_unused(node: DRSNode) -> None:
    """``tick_cpu`` keeps the deadline loop's tick thread on one CPU: where the ticks run on the
    executor's thread instead, a ``tick_cpu`` given is ignored, and the node says so."""
    if node.get_parameter("tick_cpu").value >= 0:
        node.get_logger().warning(
            "tick_cpu is ignored: the ticks run on the executor's thread here "
            "(--managed, executor single or use_sim_time), not on the deadline loop's"
        )


def report_tick_policy(node: DRSNode, policy: TickPolicy) -> None:
    """Say at start which policy the tick runs under (and why not SCHED_FIFO, when asked for
    and refused): a log line, the diagnostics' ``tick_policy`` and a ``scheduling`` record of
    the effect record (in the bag)."""
    text = policy.text()
    node.effects.tick_policy = text
    if policy.note:
        node.get_logger().warning(f"tick thread: {text}")
    else:
        node.get_logger().info(f"tick thread: {text}")
    level = DiagnosticStatus.WARN if policy.note else DiagnosticStatus.OK
    node.effects.event(
        "scheduling",
        "scheduling",
        level,
        policy.note,
        None,
        {"policy": policy.name, "priority": policy.priority, "cpu": policy.cpu},
        node.get_clock().now().nanoseconds,
    )


def run() -> None:
    """``drs-node`` and ``python -m drs_ros``: :func:`main`, then the process ends with its
    status. By then both recordings are finished, the node is destroyed and rclpy is shut down;
    the exit handlers registered in Python run (rclpy's logging, rerun's), and then the process
    ends without the rest of the interpreter's and the libraries' teardown: Fast DDS's, in
    libfastrtps 2.14's own threads, dereferenced NULL in 1 stop in some hundreds under load
    (exit -11 after ``recordings finished``; the kernel's log names the library)."""
    status = main()
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def refuse_unknown_options(own: list[str]) -> bool:
    """Say so and return True when ``own`` (drs-node's options before ``--ros-args``) holds an
    option drs-node does not take: a typo (``--managd``) must not start another kind of node."""
    unknown = [a for a in own if a.startswith("-")]
    if unknown:
        print(
            f"drs-node: refused to start: unrecognized arguments: {' '.join(unknown)} "
            "(drs-node takes "
            "--managed, --help and ROS arguments after --ros-args)",
            file=sys.stderr,
        )
    return bool(unknown)


def start_rclpy(args: list[str], stop: StopRequest) -> int | None:
    """``rclpy.init`` with ``args``; None when started, else the exit status: a refusal (2, one
    line) for ROS arguments rcl refuses (a ``--params-file`` missing or malformed), 0 for a
    stop asked for meanwhile."""
    if stop.requested:
        return stopped_before_start(stop)
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except RCLError as exc:
        print(
            f"drs-node: refused to start: the ROS arguments: {without_source_location(str(exc))}",
            file=sys.stderr,
        )
        return EXIT_REFUSED
    if stop.requested:
        rclpy.try_shutdown()
        return stopped_before_start(stop)
    return None


def stopped_before_start(stop: StopRequest) -> int:
    """A SIGINT or SIGTERM before the node was made: one line, status 0, nothing created."""
    print(
        f"drs-node: stopped by {stop.signal_name or 'a stop request'} while starting, "
        "nothing created",
        file=sys.stderr,
    )
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Console script ``drs-node [--managed] [--help]`` (``--ros-args -p name:=value`` or
    ``--params-file FILE`` as usual). ``--help`` prints :func:`~.parameters.usage_text` and
    returns 0, starting nothing. Returns 0 on SIGINT/SIGTERM, with both recordings finished;
    1 when a recording is incomplete (one line on stderr for each, naming what it lacks: a bag
    cut by a full disk or removed, its summary or metadata.yaml, the end of the .rrd, items
    lost to errors); 2 when an option, the ROS arguments, the parameters or the recording
    paths are refused (one line, nothing created); 4 when an error of its own ends it while
    it runs (one line; the recordings are finished). A managed node's refused transitions are
    named at the stop too, and status 2 when nothing worse happened. docs/cli.md."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    args = list(sys.argv if argv is None else argv)
    own_end = args.index("--ros-args") if "--ros-args" in args else len(args)
    managed = "--managed" in args[:own_end]
    if managed:
        args.remove("--managed")
    own = args[1 : args.index("--ros-args")] if "--ros-args" in args else args[1:]
    if "-h" in own or "--help" in own:  # before rclpy: nothing is started
        print(usage_text())
        return EXIT_OK
    if refuse_unknown_options(own):
        return EXIT_REFUSED
    stop = StopRequest()
    stop.install()  # before rclpy starts: a signal during start-up is a stop too
    # the other threads' Python work (reading a large trajectory, a chunk's index, a rerun
    # batch) hands the GIL to the real-time tick within this [s] when the tick wakes up
    # (CPython's default: 5 ms, more than a publish period at 250 Hz)
    sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
    refused = start_rclpy(args, stop)
    if refused is not None:
        return refused
    node = None
    rc = EXIT_OK
    try:
        try:
            node = ManagedDRSNode() if managed else DRSNode(tick_timer=False)
        except (DRSError, DRSRosError, ParameterException) as exc:  # a parameter, a path
            print(f"drs-node: refused to start: {exc}", file=sys.stderr)
            return EXIT_REFUSED
        node.stop_request = stop  # a long tick ends at the next physics step once asked
        # what start-up made (numba, rclpy, the model) lives as long as the node: out of the
        # collector's way, a full collection pass takes ~0.3 ms instead of ~70 ms (a tick late)
        gc.collect()
        gc.freeze()
        if (
            not managed
            and node.get_parameter("executor").value == "deadline"
            and node.timer is None
        ):
            run_deadline_loop(node, stop)
        else:
            if not managed and node.timer is None:  # executor 'single': the tick is a timer
                node.timer = node.create_timer(node.publish_period, node.tick)
            warn_tick_cpu_unused(node)
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            spin_until_stopped(node, executor, stop)
            executor.shutdown(timeout_sec=1.0)
    except (DRSError, DRSRosError) as exc:  # the node's own failure while it ran: no refusal
        print(
            f"drs-node: stopped by an error while running: {type(exc).__name__}: {exc}",
            file=sys.stderr,
        )
        rc = EXIT_INTERNAL
    finally:
        incomplete, refused = [], []
        if node is not None:
            # a managed node's cleanups may have finished them already: the lines of every
            # cycle are kept
            incomplete = node.close_recordings()
            refused = list(node.refused) if managed else []
            node.destroy_node()
        rclpy.try_shutdown()
    # the recordings are finished: a further SIGINT/SIGTERM (a second Ctrl-C) is ignored, not
    # left to interpreter shutdown, which restores the default action (killed: exit -2)
    stop.ignore_further()
    return report_stop(rc, incomplete, refused, stop)


def report_stop(rc: int, incomplete: list[str], refused: list[str], stop: StopRequest) -> int:
    """Name on stderr each lifecycle transition ``refused`` and each recording ``incomplete``
    (of every cycle of a managed node), and the stop; the exit status (docs/cli.md): ``rc``
    when an error ended the run, else 1 when a recording is incomplete, else 2 when a
    transition was refused (a configure: a path, a parameter), else 0."""
    for line in refused + incomplete:
        print(f"drs-node: {line}", file=sys.stderr)
    if rc == EXIT_OK and incomplete:
        rc = EXIT_FAILED
    elif rc == EXIT_OK and refused:
        rc = EXIT_REFUSED
    if stop.signal_name:
        done = "recordings incomplete (above)" if incomplete else "recordings finished"
        print(f"drs-node: stopped by {stop.signal_name}, {done}", file=sys.stderr)
    return rc


__all__ = [
    "StopRequest",
    "end_idle_wait",
    "main",
    "report_stop",
    "report_tick_policy",
    "run",
    "run_deadline_loop",
    "spin_until_stopped",
]
