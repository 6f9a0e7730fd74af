"""SIGINT and SIGTERM while a command line starts or computes, for every drs console script
(``drs``, ``drs-bag``, ``drs-node``): a stop ends the process with status 0, one line on stderr
and no traceback (docs/cli.md).

* :func:`exit_at_once_on_signal`: from a console script's first line until the program installs
  its own stop (the imports: numpy's, scipy's, rclpy's, numba's, a second or more, which a flag
  would only let run on): nothing exists yet that a stop must finish, so the process ends at once.
* :func:`interrupt_on_signal`: while a computation that writes nothing until its end runs
  (``drs excite``, ``drs-bag check``): both signals raise :class:`KeyboardInterrupt`, which
  unwinds the ``with`` and ``finally`` blocks (a Dask cluster closed, a half-written output
  removed) before the command line prints its one line.
"""

from __future__ import annotations

import os
import signal

#: The signals that ask for a stop.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def exit_at_once_on_signal(prog: str) -> dict:
    """Until the program installs its own stop: SIGINT or SIGTERM ends the process at once, with
    status 0 and the line ``PROG: stopped by SIGNAL while starting, nothing created``. Returns
    the handlers the signals had."""

    def exit_now(signum, frame) -> None:
        line = f"{prog}: stopped by {signal.Signals(signum).name} while starting, nothing created"
        os.write(2, (line + "\n").encode())
        os._exit(0)

    return {sig: signal.signal(sig, exit_now) for sig in STOP_SIGNALS}


#: The names of the signals :func:`interrupt_on_signal`'s handler took, in order.
_RECEIVED: list[str] = []


def interrupt_on_signal() -> None:
    """SIGINT and SIGTERM both raise :class:`KeyboardInterrupt` in the main thread (Python's
    SIGTERM would end the process without unwinding anything), and are noted
    (:func:`signal_received`): a C extension may turn the interrupt into an error of its own
    (pybind11's ``TypeError`` out of rclpy's ``deserialize_message``), which must not be
    reported as a damaged bag."""

    def interrupt(signum, frame) -> None:
        _RECEIVED.append(signal.Signals(signum).name)
        raise KeyboardInterrupt

    _RECEIVED.clear()  # a caller in the same process may run several commands
    for sig in STOP_SIGNALS:
        signal.signal(sig, interrupt)


def signal_received() -> str | None:
    """The name of the last signal :func:`interrupt_on_signal`'s handler took, or None."""
    return _RECEIVED[-1] if _RECEIVED else None


def ignore_signals() -> None:
    """SIGINT and SIGTERM ignored: the command's work and output are done, and a signal now
    must not turn into the default action (killed, status -15) on the way out."""
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


def end_signals(previous: dict, console_script: bool) -> None:
    """At a command's end: a console script ignores further signals (:func:`ignore_signals`);
    a caller in the same process (a test, a benchmark) gets its handlers back."""
    if console_script:
        ignore_signals()
    else:
        restore_signals(previous)


def restore_signals(previous: dict) -> None:
    """Give the signals back the handlers :func:`exit_at_once_on_signal` returned."""
    for sig, handler in previous.items():
        signal.signal(sig, handler)


__all__ = [
    "STOP_SIGNALS",
    "end_signals",
    "exit_at_once_on_signal",
    "ignore_signals",
    "interrupt_on_signal",
    "restore_signals",
    "signal_received",
]
