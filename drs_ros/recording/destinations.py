"""Where a recording goes, checked before anything is written: a new bag directory
(:func:`check_new_bag`), a new ``.rrd`` file (:func:`check_new_rrd`), the writable directory they
are created in (:func:`check_writable_parent`), and the loopback URL of a live rerun stream
(:func:`check_connect_url`). An earlier recording is never overwritten.
"""

from __future__ import annotations

import ipaddress
import os
import shutil
from pathlib import Path
from urllib.parse import urlsplit

from .errors import RecordingError, RerunLogError

#: URL schemes of a rerun gRPC endpoint (rerun-sdk 0.41), and an example of a valid URL.
CONNECT_SCHEMES = ("rerun", "rerun+http", "rerun+https")
CONNECT_URL_EXAMPLE = "rerun+http://127.0.0.1:9876/proxy"


def check_new_bag(bag_dir: str | os.PathLike) -> Path:
    """Refuse a bag directory that would overwrite or cannot be created; create nothing.

    Returns the directory. Raises :class:`RecordingError` naming the path and the reason: it is a
    file, it already holds files (an earlier recording is never overwritten), or its nearest
    existing parent is not a writable directory.
    """
    path = Path(bag_dir)
    if not path.name:
        raise RecordingError(f"a bag path must name a directory, got {str(bag_dir)!r}")
    if path.exists() and not path.is_dir():
        raise RecordingError(f"bag path {str(path)!r} exists and is a file")
    if path.is_dir() and any(path.iterdir()):
        raise RecordingError(
            f"bag path {str(path)!r} already holds files (an earlier recording is never "
            "overwritten): choose a new path"
        )
    check_writable_parent(path)
    return path


def remove_unfinished_bag(recorder, bag_dir: str | os.PathLike, made: bool) -> None:
    """Leave nothing of a bag that a tool (recover, merge) could not finish: the recorder's
    ``.mcap`` and ``metadata.yaml``, and ``bag_dir`` itself when the tool ``made`` it."""
    try:
        recorder.discard()
    except OSError:  # closing flushes what could not be written: the same error again
        pass
    for path in (recorder.path, recorder.metadata_path):
        path.unlink(missing_ok=True)
    if made:
        shutil.rmtree(bag_dir, ignore_errors=True)


def check_writable_parent(path: str | os.PathLike) -> Path:
    """The nearest existing ancestor of ``path`` must be a writable directory (where ``path`` and
    its missing parents can be created). Raises :class:`RecordingError` otherwise."""
    parent = Path(path).absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise RecordingError(
            f"cannot create {str(path)!r}: {str(parent)!r} is not a writable directory"
        )
    return parent


def check_new_rrd(path: str | os.PathLike) -> Path:
    """Refuse an ``.rrd`` path that exists (an earlier recording is never overwritten) or cannot
    be created; create nothing. Raises :class:`RerunLogError` naming the path and the reason."""
    path = Path(path)
    if path.exists() or path.is_symlink():
        raise RerunLogError(
            f"rrd path {str(path)!r} already exists (an earlier recording is never "
            "overwritten): choose a new path"
        )
    try:
        parent = check_writable_parent(path)
    except RecordingError as exc:
        raise RerunLogError(str(exc)) from None
    if parent == path.parent:  # probe: root passes os.access checks that the filesystem refuses
        try:
            os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            os.unlink(path)
        except OSError as exc:
            raise RerunLogError(f"cannot create rrd {str(path)!r}: {exc.strerror}") from None
    return path


def check_connect_url(url: str) -> str:
    """Check the URL of a rerun gRPC endpoint: ``rerun[+http|+https]://HOST:PORT/proxy`` with HOST
    on loopback (``127.0.0.0/8``, ``::1`` or ``localhost``; other names are not resolved, since
    a name may lead off loopback). Returns ``url``; raises :class:`RerunLogError` with the reason.
    """
    if not isinstance(url, str) or not url.strip():
        raise RerunLogError(
            f"rerun connect URL must be a non-empty string such as {CONNECT_URL_EXAMPLE!r}, "
            f"got {url!r}"
        )
    parts = urlsplit(url)
    try:
        port = parts.port
    except ValueError:
        port = -1
    host = (parts.hostname or "").lower()
    if parts.scheme not in CONNECT_SCHEMES:
        reason = "the scheme must be one of " + ", ".join(f"{s}://" for s in CONNECT_SCHEMES)
    elif not host:
        reason = "it names no host"
    elif port is None or port == -1 or port == 0:
        reason = "it needs a port in 1..65535"
    elif parts.path != "/proxy":
        reason = "the path must be /proxy"
    elif parts.query or parts.fragment or parts.username or parts.password:
        reason = "it may hold no user, query or fragment"
    else:
        reason = None
    if reason is not None:
        raise RerunLogError(
            f"invalid rerun connect URL {url!r}: {reason} (e.g. {CONNECT_URL_EXAMPLE!r})"
        )
    if host != "localhost":
        try:
            loopback = ipaddress.ip_address(host).is_loopback
        except ValueError:
            raise RerunLogError(
                f"rerun connect URL {url!r} refused: host {host!r} is a name other than "
                "'localhost'; give a loopback address (127.0.0.1 or ::1), since a name may lead "
                "off loopback and these machines send nothing off loopback"
            ) from None
        if not loopback:
            raise RerunLogError(
                f"rerun connect URL {url!r} refused: host {host!r} is not on loopback "
                "(127.0.0.0/8, ::1, localhost), and these machines send nothing off loopback"
            )
    return url


__all__ = [
    "CONNECT_SCHEMES",
    "CONNECT_URL_EXAMPLE",
    "check_connect_url",
    "check_new_bag",
    "check_new_rrd",
    "check_writable_parent",
]
