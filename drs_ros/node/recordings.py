"""The node's recordings: the rosbag2 MCAP bag and the rerun recording (a file, a live viewer, or
both), each a part that owns its failures (:class:`BagRecording`, :class:`RerunRecording`, each
with its :class:`RecordingHealth`).

Both paths are checked before anything is created, and a node that fails to start leaves nothing
behind; both are finished when the node stops. What a failure does (docs/ros.md, "Recordings"):

* an I/O error (``OSError``: a full disk, the file or its directory removed, rerun's file writer
  stopped) is permanent: that recording stops, and diagnostics say so at ERROR for the rest of the
  run. The other recording and the actuator go on.
* any other exception of one write (a programming error, a value a recorder refuses) loses that
  item only: it is logged at ERROR with its traceback (the first of each recording; then one line
  a second), counted (diagnostics ``bag_errors``, ``rerun_errors``) and a trouble of the window;
  the recording goes on.
* at the stop each recording is finished (a failed bag is closed as it is: what was flushed stays,
  for ``drs-bag recover``), and :meth:`NodeRecordings.close` returns one line per
  recording that is incomplete, naming what it lacks; ``drs-node`` prints them and exits 1.

A managed node records anew at each configure: the first recordings go to ``bag_path`` and
``rrd_path``, the n-th later ones to ``<bag_path>_n`` and ``<rrd stem>_n.rrd``
(:func:`cycle_path`); a name that exists is refused as at start, never overwritten. The lines of
every cycle's recordings are kept for the stop.

:class:`NodeRecordings` is a part of :class:`drs_ros.node.adapter.DRSNode`, constructed with the
node's logger; it holds the recordings.
"""

from __future__ import annotations

import shutil
import traceback
from pathlib import Path

from drs_model.errors import DRSError

from ..errors import DRSRosError
from ..log_throttle import LogThrottle
from .effect_record import error_text

#: The fewest states sent to rerun at a time. A ``send_columns`` batch costs ~4 ms whatever its
#: size: every 250 samples it was 2/3 of the rerun recording's cost at 1 kHz. One second of
#: states at a time (1000 at 1 kHz) cut it to ~9 us a state; a live viewer sees them up to a
#: second late, and a process killed with SIGKILL loses up to a second of the .rrd. The batch
#: is sent by the recorder's sender thread, never in the tick (a burst of milliseconds there was
#: a missed deadline every second at 1 kHz).
RERUN_BATCH_MIN = 250


def cycle_path(path: str, cycle: int, keep_suffix: bool = False) -> str:
    """Where the recording of a managed node's ``cycle``-th configure goes (0: the first):
    ``path`` itself at 0, else ``path`` with ``_<cycle>`` appended to its name, before its
    suffix when ``keep_suffix`` (``runs/a`` -> ``runs/a_2``, ``a.rrd`` -> ``a_2.rrd``). '' stays
    '' (nothing recorded). rosbag2's recorder, asked to record again to a bag that exists,
    appends ``(n)`` (docs/ros.md, "Lifecycle")."""
    if not path or cycle == 0:
        return path
    p = Path(path)
    if keep_suffix and p.suffix:
        return str(p.with_name(f"{p.stem}_{cycle}{p.suffix}"))
    return str(p.with_name(f"{p.name}_{cycle}"))


class RecordingHealth:
    """The failures of one recording, ``name`` (e.g. ``bag '/runs/a'``): its permanent
    :attr:`failure` (an I/O error: it stopped) and its other errors (each an item lost)."""

    def __init__(self, name: str, logger, on_error=None) -> None:
        self.name = name
        self._on_error = on_error  # called with the reason of each item lost
        #: Why the recording stopped ('' while it goes on).
        self.failure = ""
        #: Items lost to other exceptions, and the last one's type and text.
        self.errors = 0
        self.last_error = ""
        self._logger = logger
        self._log_error = LogThrottle(logger.error)  # after the first: one line a second

    def run(self, action, *args, **kwargs):
        """``action(*args, **kwargs)``, or None when it stopped or the action failed (module
        docstring: an OSError stops the recording, any other exception is counted)."""
        if self.failure:
            return None
        try:
            return action(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001 - a bug in one write must not stop the node
            self.take(exc)
        return None

    def take(self, exc: Exception, items: int = 1) -> None:
        """An exception that lost ``items`` items (raised in :meth:`run`, or met by a
        recorder's own thread): an OSError stops the recording, any other is counted."""
        if isinstance(exc, OSError):
            self.fail(error_text(exc))
            return
        self.errors += items
        self.last_error = error_text(exc)
        if self._on_error is not None:
            self._on_error(f"{self.name}: {self.last_error}")
        if self.errors == items:  # loudly, with where it came from; then one line a second
            where = "".join(traceback.format_exception(exc))
            self._logger.error(
                f"{self.name}: {items} items were not recorded (the recording goes on): {where}"
            )
        else:
            self._log_error(
                f"{self.name}: {self.errors} items not recorded, last: {self.last_error}"
            )

    def fail(self, reason: str) -> None:
        """Stop the recording for good (the first reason is kept)."""
        if not self.failure:
            self.failure = reason
            self._logger.error(
                f"{self.name} stopped: {reason}; the actuator and the other recording go on"
            )

    def status(self, going: str) -> str:
        """For diagnostics: ``going`` (what it recorded) while it goes on, then the failure; the
        errors counted either way."""
        text = f"failed: {self.failure}" if self.failure else going
        if self.errors:
            text += f"; {self.errors} items not recorded (last: {self.last_error})"
        return text

    def lost(self) -> list[str]:
        """The items lost, as a line for the stop (empty when none)."""
        if not self.errors:
            return []
        return [
            f"{self.name} lacks {self.errors} items that could not be recorded (last: "
            f"{self.last_error})"
        ]


def _unfinished(name: str, exc: Exception) -> str:
    """The stop's line for a finish that raised: the recorders' own errors and I/O errors name
    what the recording lacks; anything else (a bug) is named with its type."""
    if isinstance(exc, OSError) or type(exc).__module__.startswith(("drs_model.", "drs_ros.")):
        return str(exc)
    return f"{name} is unfinished: {error_text(exc)}"


class BagRecording:
    """The node's MCAP bag (a :class:`~drs_ros.recording.mcap_recorder.McapRecorder`) and its
    failures."""

    def __init__(self, recorder, logger, on_error=None) -> None:
        self.recorder = recorder
        self.health = RecordingHealth(f"bag {str(recorder.bag_dir)!r}", logger, on_error)

    def write(self, topic: str, msg, now_ns: int) -> int | None:
        """Append a message (or its exact CDR bytes); its sequence number, or None when it was
        not recorded."""
        return self.health.run(self.recorder.write, topic, msg, log_time_ns=now_ns)

    def write_many(self, records, now_ns: int) -> None:
        """Append a tick's ``(topic, bytes)`` records, logged at ``now_ns``, under one lock. A
        batch the recorder refuses (it refuses before writing any) is written record by record,
        so that only the records at fault are lost, each counted."""
        if self.health.failure:
            return
        try:
            self.recorder.write_many(records, now_ns)
        except OSError as exc:
            self.health.fail(error_text(exc))
        except Exception:  # noqa: BLE001 - which record is at fault: each on its own
            for topic, data in records:
                self.write(topic, data, now_ns)

    def poll(self) -> None:
        """Take in a failure the recorder's flush thread met (a removed file, a full disk)."""
        if self.recorder.io_error is not None:
            self.health.fail(error_text(self.recorder.io_error))

    def status(self) -> str:
        s = self.recorder.stats()
        return self.health.status(f"{s.message_count} messages, {s.flush_count} flushes")

    def finish(self) -> list[str]:
        """Finish the bag (a failed one is closed as it is); what it lacks, one line each."""
        self.poll()
        lines = []
        if self.health.failure:
            self.recorder.abandon()
            s = self.recorder.stats()
            if not self.recorder.path.exists():
                lines.append(
                    f"{self.health.name} is lost: {self.health.failure}; nothing of "
                    f"its {s.message_count} messages remains"
                )
            else:
                lines.append(
                    f"{self.health.name} is incomplete: recording stopped after "
                    f"{s.message_count} messages ({self.health.failure}); it has no summary, "
                    f"footer or metadata.yaml: `drs-bag recover` restores the "
                    f"{s.messages_flushed} messages flushed before the failure"
                )
        else:
            try:
                self.recorder.finish()
            except Exception as exc:  # noqa: BLE001 - whatever it is, the stop names it
                lines.append(_unfinished(self.health.name, exc))
        return lines + self.health.lost()


class RerunRecording:
    """The node's rerun recording (a :class:`~drs_ros.recording.rerun_recorder.RerunRecorder`)
    and its failures."""

    def __init__(self, recorder, logger, on_error=None) -> None:
        self.recorder = recorder
        target = recorder.path if recorder.path is not None else recorder.connect_url
        self.health = RecordingHealth(f"rerun recording {str(target)!r}", logger, on_error)

    def log_state(self, t: float, q, piston_force: float) -> None:
        if self.recorder.send_failed:  # taken here: the one thread that counts the errors
            self._take_send_failures()
        self.health.run(self.recorder.log_state, t, q, piston_force)

    def _take_send_failures(self) -> None:
        """The batches the recorder's sender could not send, each its states lost."""
        for failure in self.recorder.take_send_failures():
            self.health.take(failure.error, failure.states)

    def poll(self) -> None:
        """Take in a failure of the file sink (rerun's writer stopped, the file removed)."""
        if self.recorder.sink_error is not None:
            self.health.fail(self.recorder.sink_error)

    def status(self) -> str:
        return self.health.status(f"{self.recorder.sample_count} samples")

    def finish(self) -> list[str]:
        """Flush and close; what the recording lacks, one line each (the batches the sender
        fails to send in the close are named by the close's error)."""
        lines = []
        self._take_send_failures()
        try:
            self.recorder.close()
        except Exception as exc:  # noqa: BLE001 - the file's end is missing: the stop names it
            lines.append(_unfinished(self.health.name, exc))
        if self.health.failure and not lines:
            lines.append(
                f"{self.health.name} is incomplete: recording stopped ({self.health.failure})"
            )
        if self.recorder.stream_error is not None:
            lines.append(
                f"{self.health.name}: the live stream was not delivered: "
                f"{self.recorder.stream_error}"
            )
        return lines + self.health.lost()


class NodeRecordings:
    """The bag and the rerun recording of one node: a part of
    :class:`drs_ros.node.adapter.DRSNode`, constructed with what it needs; it holds the
    recordings (``bag`` and ``rrd``: None when not recorded), their recorders (``recorder``,
    ``rerun``), how many recordings were finished (``cycles``: a discarded one is not) and the
    lines of the recordings found incomplete (``problems``, of every cycle).

    :meth:`open` checks both paths, then creates both recorders; on any failure it removes what
    was made. ``lost(reason)`` is called for each item a recording loses (a trouble of the
    diagnostics window)."""

    def __init__(self, logger, lost) -> None:
        self._logger, self._lost = logger, lost
        self.recorder = self.rerun = None
        self.bag = self.rrd = None
        self.problems: list[str] = []
        self.cycles = 0
        self._made_bag_dir = False

    def open(
        self,
        bag: str,
        rrd: str,
        live: str,
        flush_period: float,
        params,
        max_draw_hz: float,
        states_hz: float = RERUN_BATCH_MIN,
    ) -> None:
        """``bag``: the MCAP bag directory, ``rrd``: the rerun file, ``live``: a rerun viewer's
        URL ('' = none of each); ``flush_period`` [s]: the bag's; ``params``: the mechanism the
        rerun recording draws, at most ``max_draw_hz`` [Hz]; ``states_hz``: the states logged
        per second [Hz], sent to rerun once a second of them (at least
        :data:`RERUN_BATCH_MIN` at a time). Opened again after :meth:`close`, the paths are
        those of the next cycle (:func:`cycle_path`)."""
        from ..recording.errors import RecordingError
        from ..recording.mcap_recorder import McapRecorder

        bag, rrd = cycle_path(bag, self.cycles), cycle_path(rrd, self.cycles, keep_suffix=True)
        self._check(bag, rrd, live)
        made_dir = bool(bag) and not Path(bag).exists()
        try:
            if bag:
                self.recorder = McapRecorder(bag, flush_period=flush_period)
                self.bag = BagRecording(self.recorder, self._logger, self._lost)
            if rrd or live:
                from ..recording.rerun_recorder import RerunRecorder

                # the mechanism drawn as often as ~/markers draws it; the series at every sample
                batch = max(RERUN_BATCH_MIN, round(states_hz))
                self.rerun = RerunRecorder(
                    rrd or None,
                    params,
                    connect_url=live or None,
                    max_draw_hz=max_draw_hz,
                    batch=batch,
                )
                self.rrd = RerunRecording(self.rerun, self._logger, self._lost)
        except Exception as exc:
            self._made_bag_dir = made_dir
            self.discard()
            if isinstance(exc, (DRSError, DRSRosError)):  # ours: its message says it all
                raise
            raise RecordingError(f"cannot start the recordings: {exc}") from exc
        self._made_bag_dir = made_dir

    def _check(self, bag: str, rrd: str, live: str) -> None:
        """Refuse a path that exists or cannot be created, and a live URL off loopback, creating
        nothing; a later cycle's refusal says where its names come from."""
        from ..recording.destinations import check_connect_url, check_new_bag, check_new_rrd

        try:
            if bag:
                check_new_bag(bag)
            if rrd:
                check_new_rrd(rrd)
            if live:
                check_connect_url(live)
        except DRSRosError as exc:
            if self.cycles == 0:
                raise
            n = self.cycles
            raise type(exc)(
                f"{exc}; configure {n + 1} of this node records to bag_path and "
                f"rrd_path with _{n} appended to the name (before .rrd): move that "
                "one away, or start a new node"
            ) from None

    def discard(self) -> None:
        """Close and delete the recordings of a node that fails to start: nothing is left."""
        if self.recorder is not None:
            self.recorder.discard()
            if self._made_bag_dir:
                shutil.rmtree(self.recorder.bag_dir, ignore_errors=True)
            self.recorder = None
        if self.rerun is not None:
            self.rerun.discard()
            self.rerun = None
        self.bag = self.rrd = None

    def record(self, topic: str, data, now_ns: int) -> int | None:
        """Append exact bytes (or a message) to the bag; the sequence number (None: not
        recorded)."""
        return None if self.bag is None else self.bag.write(topic, data, now_ns)

    def record_many(self, records, now_ns: int) -> None:
        """A tick's ``(topic, bytes)`` records into the bag, if any."""
        if self.bag is not None:
            self.bag.write_many(records, now_ns)

    def log_state(self, st) -> None:
        """The state ``st`` into the rerun recording, if any."""
        if self.rrd is not None:
            self.rrd.log_state(st.t, st.q, st.piston_force)

    def status(self) -> dict[str, str]:
        """Diagnostics: ``bag`` and ``rerun``, each what it recorded or how it failed; a failure
        a recorder's own thread met is taken in here."""
        out = {}
        for key, part in (("bag", self.bag), ("rerun", self.rrd)):
            if part is not None:
                part.poll()
            out[key] = "off" if part is None else part.status()
        return out

    def failures(self) -> list[str]:
        """The recordings stopped for good, each with its reason (for the diagnostics level)."""
        return [
            f"{p.health.name} stopped: {p.health.failure}"
            for p in (self.bag, self.rrd)
            if p is not None and p.health.failure
        ]

    def close(self) -> list[str]:
        """Finish the MCAP bag and the rerun file (idempotent); one line per recording that is
        incomplete, naming what it lacks (empty: both complete), kept for later calls and
        later cycles: the lines of every cycle."""
        if self.bag is not None or self.rrd is not None:
            self.cycles += 1  # the next open records to the next cycle's names
        for part in (self.rrd, self.bag):
            if part is not None:
                lines = part.finish()
                for line in lines:
                    self._logger.error(line)
                self.problems += lines
        self.bag = self.rrd = None
        self.recorder = self.rerun = None
        return list(self.problems)


__all__ = ["BagRecording", "NodeRecordings", "RecordingHealth", "RerunRecording"]
