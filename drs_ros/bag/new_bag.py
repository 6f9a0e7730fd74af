"""The new bag a tool writes (``drs-bag recover``, ``merge``): complete, or nothing of it left."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from drs_ros.recording.destinations import remove_unfinished_bag
from drs_ros.recording.errors import RecordingError
from drs_ros.recording.mcap_recorder import McapRecorder


@contextmanager
def new_bag(out: str | os.PathLike) -> Iterator[McapRecorder]:
    """A recorder of the new bag directory ``out`` (refused beforehand by
    :func:`drs_ros.recording.destinations.check_new_bag` if it would overwrite). Nothing of
    ``out`` is left when the recorder cannot open it (:class:`RecordingError`, raised) or the
    block raises: the recorder's files, and ``out`` itself if it did not exist before."""
    made = not Path(out).exists()
    try:
        rec = McapRecorder(out, flush_thread=False)
    except RecordingError:
        if made:
            shutil.rmtree(out, ignore_errors=True)
        raise
    try:
        yield rec
    except BaseException:
        remove_unfinished_bag(rec, out, made)
        raise
