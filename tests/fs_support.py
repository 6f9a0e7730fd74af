"""A small file system that fills up, for tests of recordings that fail (``No space left on
device`` for real, not a mock): a tmpfs of a given size mounted over a test's directory.

Mounting takes root (or CAP_SYS_ADMIN), as on these machines and on CI, which runs as root; the
mount(2) and umount2(2) calls go through libc directly, so no ``mount`` binary is needed. Where
the mount is not permitted the test is skipped, except under CI, where it fails: no skip hides a
missing capability there.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
from pathlib import Path

import pytest

#: umount2's flag: detach now, free when no longer busy (a node killed mid-test may hold a file).
MNT_DETACH = 2


def _libc():
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    libc.mount.argtypes = [ctypes.c_char_p] * 3 + [ctypes.c_ulong, ctypes.c_char_p]
    libc.umount2.argtypes = [ctypes.c_char_p, ctypes.c_int]
    return libc


@contextlib.contextmanager
def small_filesystem(path: Path, size_bytes: int):
    """Mount a tmpfs of ``size_bytes`` at ``path`` (created) for the ``with`` block."""
    path.mkdir(parents=True, exist_ok=True)
    libc = _libc()
    options = f"size={size_bytes},mode=0755".encode()
    if libc.mount(b"tmpfs", str(path).encode(), b"tmpfs", 0, options) != 0:
        err = ctypes.get_errno()
        reason = (
            f"cannot mount a {size_bytes}-byte tmpfs at {path}: {os.strerror(err)} "
            "(the test needs root or CAP_SYS_ADMIN)"
        )
        if os.environ.get("CI"):
            pytest.fail(reason)
        pytest.skip(reason)
    try:
        yield path
    finally:
        libc.umount2(str(path).encode(), MNT_DETACH)
