"""A stop asked for by SIGINT or SIGTERM: :class:`StopRequest`, shared by ``drs-node`` and
``drs-bag play``.

A Python signal handler runs in the main thread between two bytecodes, wherever that thread is:
inside a ``threading.Event.wait`` (holding the event's lock), between a bag write and its count,
inside a tick. A handler that takes a lock (``Event.set`` does) can therefore deadlock on a lock
its own thread holds, and one that raises (``KeyboardInterrupt``) leaves whatever it interrupted
half done. This handler does neither: it sets a plain attribute, and the program's loops read it
where stopping is safe (between two ticks, between two physics steps, between two messages
played), then stop in order.
"""

from __future__ import annotations

import signal

from drs_model.cli.start_signals import STOP_SIGNALS


class StopRequest:
    """A stop asked for by SIGINT or SIGTERM (or by a caller), read by the loops between two
    safe points (``requested``).

    rclpy's own signal handlers are not installed (``SignalHandlerOptions.NO``): Python's raise
    ``KeyboardInterrupt`` at any bytecode (between a bag write and its count, say), and rclpy's
    shut the context down under running callbacks. This handler only sets a flag; the stop then
    runs in order."""

    def __init__(self) -> None:
        self.requested = False  # a plain flag: setting it takes no lock a signal could interrupt
        self.signal_name = ""

    def __call__(self, signum=None, frame=None) -> None:
        if signum is not None:
            self.signal_name = signal.Signals(signum).name
        self.requested = True

    def install(self) -> dict:
        """Take SIGINT and SIGTERM; returns the handlers they had (for :meth:`restore`)."""
        return {sig: signal.signal(sig, self) for sig in STOP_SIGNALS}

    @staticmethod
    def restore(previous: dict) -> None:
        """Give the signals back the handlers :meth:`install` returned."""
        for sig, handler in previous.items():
            signal.signal(sig, handler)

    def ignore_further(self) -> None:
        """Ignore SIGINT and SIGTERM from now on (the stop is done; a second Ctrl-C must not
        turn into the default action, which kills)."""
        for sig in STOP_SIGNALS:
            signal.signal(sig, signal.SIG_IGN)


__all__ = ["STOP_SIGNALS", "StopRequest"]
