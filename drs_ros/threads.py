"""Threads the operating system knows by their Python names.

Linux shows a thread's name in ``/proc/<pid>/task/<tid>/comm``, which ``top -H``, ``perf``,
``py-spy`` and the benchmarks read to tell one thread's CPU from another's; a Python thread is
otherwise ``python`` there, like every other. :class:`NamedThread` gives the kernel the thread's
Python name (its first 15 bytes: the kernel's limit) as its first act. Elsewhere than on Linux,
or where the C library is not reachable, nothing is named and nothing fails.
"""

from __future__ import annotations

import ctypes
import sys
import threading

#: ``prctl``'s option that names the calling thread (linux/prctl.h).
PR_SET_NAME = 15
#: The longest name the kernel keeps [bytes] (16 with the terminating zero).
OS_NAME_BYTES = 15


def _prctl():
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


_PRCTL = _prctl()


def name_os_thread(name: str) -> bool:
    """Give the calling thread ``name`` (its first :data:`OS_NAME_BYTES` bytes of UTF-8) in the
    operating system; whether it was named."""
    if _PRCTL is None:
        return False
    raw = name.encode("utf-8", "replace")[:OS_NAME_BYTES]
    return _PRCTL(PR_SET_NAME, ctypes.c_char_p(raw), 0, 0, 0) == 0


class NamedThread(threading.Thread):
    """A :class:`threading.Thread` that names itself in the operating system
    (:func:`name_os_thread`) before it runs its target."""

    def run(self) -> None:
        name_os_thread(self.name)
        super().run()


__all__ = ["OS_NAME_BYTES", "NamedThread", "name_os_thread"]
