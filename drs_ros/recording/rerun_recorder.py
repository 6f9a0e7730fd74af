"""rerun recording of the DRS mechanism and its time series: to an ``.rrd`` file, live to a
running rerun viewer or server, or both.

One explicit ``rr.RecordingStream``, one timeline ``sim_time`` (a duration [s]). Its sinks: a
file (``path``), a gRPC connection (``connect_url``, e.g. ``rerun+http://127.0.0.1:9876/proxy``,
the address ``rerun`` prints when it starts), or both at once (``set_sinks``). The URL must name a
loopback host: these machines send nothing off loopback. Geometry comes from
:mod:`drs_model.kinematics`; nothing is computed here beyond arranging points into drawings.

Entities (ground frame, metres; 2D view ``mechanism``):

* ``mechanism/fia_box`` (static): the FIA box, ``box_width x box_height`` from the origin;
* ``mechanism/main_wing``, ``mechanism/pylon`` (static): closed outlines;
* ``mechanism/piston``: A -> B; ``mechanism/link``: B -> C; ``mechanism/flap``: the flap outline
  (closed); ``mechanism/gap``: the vertical segment from R to the height of the flap tip T;
  ``mechanism/pins``: A, B, C, D, R, T.

Time series (``series/...``): ``stroke`` [m], ``flap_angle_deg`` [deg], ``gap`` [m],
``piston_force`` [N].

Drawings are decimated to at most ``max_draw_hz`` per second of simulated time; the scalars are
logged at every sample. Everything goes through ``send_columns``, since logging scalars one
``rr.log`` at a time costs 50-80 us each. :meth:`RerunRecorder.log_state` only writes a row of
its arrays (about a microsecond); every ``batch`` samples it hands the full arrays to the
recorder's sender thread (:mod:`~drs_ros.recording.rerun_sender`), which computes the series and
the drawings and calls ``send_columns``: the milliseconds a batch costs are never the caller's.
A batch the sender fails to send is kept (:meth:`RerunRecorder.take_send_failures`).

A failing file sink is seen while recording (:mod:`~drs_ros.recording.rerun_sink`); :meth:`close`
then raises :class:`RerunSinkError` naming what the file lacks.

:meth:`~RerunRecorder.log_state`, :meth:`~RerunRecorder.flush`, :meth:`~RerunRecorder.close` and
:meth:`~RerunRecorder.discard` may be called from different threads: a state whose
:meth:`~RerunRecorder.log_state` returned is in the recording, one logged after the close is
refused.
"""

from __future__ import annotations

import math
import os
import shutil
import threading
from collections.abc import Sequence

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from drs_model import kinematics
from drs_model.constraints import PSI3, S
from drs_model.params import DRSParams

from ..drawing import PIN_NAMES, moving_drawings, still_drawings
from .destinations import check_connect_url, check_new_rrd
from .errors import RerunLogError
from .rerun_sender import BatchSender, SendFailure
from .rerun_sink import FileSinkWatch, RerunSinkError

TIMELINE = "sim_time"
#: How long :meth:`RerunRecorder.close` waits for a live stream to drain [s].
STREAM_FLUSH_TIMEOUT_S = 2.0
#: Series entity -> (label, colour).
SERIES = {
    "series/stroke": ("stroke [m]", (31, 119, 180)),
    "series/flap_angle_deg": ("flap angle psi3 [deg]", (255, 127, 14)),
    "series/gap": ("gap [m]", (44, 160, 44)),
    "series/piston_force": ("piston force [N]", (214, 39, 40)),
}
#: Moving drawings.
DRAWINGS = (
    "mechanism/piston",
    "mechanism/link",
    "mechanism/flap",
    "mechanism/gap",
    "mechanism/pins",
)
_COLORS = {
    "mechanism/piston": (120, 120, 120),
    "mechanism/link": (70, 70, 200),
    "mechanism/flap": (214, 39, 40),
    "mechanism/gap": (44, 160, 44),
    "mechanism/pins": (0, 0, 0),
    "mechanism/main_wing": (40, 40, 40),
    "mechanism/pylon": (110, 110, 110),
    "mechanism/fia_box": (160, 160, 160),
}


def default_blueprint() -> rrb.Blueprint:
    """A 2D view of the mechanism beside stacked time-series views."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="mechanism", origin="/mechanism"),
            rrb.Vertical(
                rrb.TimeSeriesView(name="stroke [m]", origin="/series/stroke"),
                rrb.TimeSeriesView(name="flap angle [deg]", origin="/series/flap_angle_deg"),
                rrb.TimeSeriesView(name="gap [m]", origin="/series/gap"),
                rrb.TimeSeriesView(name="piston force [N]", origin="/series/piston_force"),
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


class RerunRecorder:
    """Write the mechanism and its time series to an ``.rrd`` file, to a running rerun viewer or
    server, or to both.

    Parameters
    ----------
    path : str or Path or None
        Output ``.rrd`` file (parent directories are created; an existing file is refused), or
        None for no file.
    params : DRSParams, optional
        Geometry (the seed by default).
    connect_url : str, optional
        Stream live to the rerun gRPC endpoint at this URL (see :func:`check_connect_url`), e.g.
        ``rerun+http://127.0.0.1:9876/proxy`` for ``rerun`` started on this machine. With a
        ``path`` too, both get the same data (``set_sinks``).
    max_draw_hz : float
        Maximum rate of mechanism drawings per second of simulated time [Hz] (> 0).
    batch : int
        Samples buffered by :meth:`log_state` before they are sent with ``send_columns``.
    application_id : str
        rerun application id.

    Notes
    -----
    Call :meth:`close` (or use ``with``) to send what is buffered and queued and flush the
    file. With ``connect_url``, :meth:`close` waits at most :data:`STREAM_FLUSH_TIMEOUT_S` for
    the stream to drain. A stream that could not be delivered is not an error (the file, if any,
    is complete): its reason is left in :attr:`stream_error`. When nothing listens at the URL,
    rerun-sdk 0.41 blocks: the constructor 5 s (10 s with a file too) and :meth:`close` about
    6 s (measured); with a listening viewer both take milliseconds.
    """

    def __init__(
        self,
        path: str | os.PathLike | None,
        params: DRSParams | None = None,
        *,
        connect_url: str | None = None,
        max_draw_hz: float = 250.0,
        batch: int = 250,
        application_id: str = "drs",
    ) -> None:
        if not (
            isinstance(max_draw_hz, (int, float)) and math.isfinite(max_draw_hz) and max_draw_hz > 0
        ):
            raise RerunLogError(f"max_draw_hz must be a finite number > 0 Hz, got {max_draw_hz!r}")
        if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
            raise RerunLogError(f"batch must be an int >= 1, got {batch!r}")
        if path is None and connect_url is None:
            raise RerunLogError("RerunRecorder needs a path, a connect_url, or both; got neither")
        self.connect_url = None if connect_url is None else check_connect_url(connect_url)
        self.path = None if path is None else check_new_rrd(path)
        #: Why the live stream could not be delivered at :meth:`close` (None: delivered or none).
        self.stream_error: str | None = None
        self.params = params if params is not None else DRSParams()
        self.max_draw_hz = float(max_draw_hz)
        self._draw_dt = 1.0 / self.max_draw_hz
        self._last_draw: float | None = None
        self.batch = int(batch)
        self.draw_count = 0
        self.sample_count = 0
        #: Scalar rows sent per series entity.
        self.scalar_rows: dict[str, int] = {}
        self._new_buffer()
        #: Held by each call that logs, hands off or closes (they may come from two threads).
        self._lock = threading.Lock()
        self.rec = self._open_sinks(application_id)
        self._closed = False
        #: The file sink's health (None: no file): its first failure, found while recording.
        self.sink = (
            None
            if self.path is None
            else FileSinkWatch(self.rec, self.path, live=connect_url is not None)
        )
        self._log_static()
        self._sender = BatchSender(self._send_logged, name="rerun-sender")

    def _open_sinks(self, application_id: str) -> rr.RecordingStream:
        """A recording stream writing to the file, the gRPC endpoint, or both."""
        made = []
        if self.path is not None:
            made = [d for d in (self.path.parent, *self.path.parent.parents) if not d.exists()]
        try:
            if self.path is not None:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            rec = rr.RecordingStream(application_id)
            if self.connect_url is None:
                rec.save(str(self.path), default_blueprint=default_blueprint())
            else:
                sinks = [rr.GrpcSink(self.connect_url)]
                if self.path is not None:
                    sinks.append(rr.FileSink(str(self.path)))
                rec.set_sinks(*sinks, default_blueprint=default_blueprint())
        except Exception as exc:
            for d in made:  # leave nothing behind
                shutil.rmtree(d, ignore_errors=True)
            raise RerunLogError(
                f"cannot open the rerun recording to {self._target}: {exc}"
            ) from exc
        return rec

    @property
    def _target(self) -> str:
        """Where the recording goes, for messages."""
        names = [repr(str(self.path))] if self.path is not None else []
        if self.connect_url is not None:
            names.append(repr(self.connect_url))
        return " and ".join(names)

    def __enter__(self) -> RerunRecorder:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    # ---- static scene ------------------------------------------------------------------------
    def _log_static(self) -> None:
        rec = self.rec
        for name, strip in still_drawings(self.params).items():
            entity = f"mechanism/{name}"
            rec.log(entity, rr.LineStrips2D([strip], colors=[_COLORS[entity]]), static=True)
        for entity, (label, color) in SERIES.items():
            rec.log(entity, rr.SeriesLines(colors=[color], names=[label]), static=True)

    # ---- geometry ----------------------------------------------------------------------------
    def _geometry(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Drawings for configurations ``q`` of shape (n, 3) (:mod:`drs_ros.drawing`): arrays
        with a leading n axis."""
        lines, pins, _force_at = moving_drawings(q, self.params)
        return {**{f"mechanism/{k}": v for k, v in lines.items()}, "mechanism/pins": pins}

    def _series(self, q: np.ndarray, force: np.ndarray) -> dict[str, np.ndarray]:
        return {
            "series/stroke": q[:, S],
            "series/flap_angle_deg": np.degrees(q[:, PSI3]),
            "series/gap": kinematics.gap(q, self.params),
            "series/piston_force": force,
        }

    # ---- streaming -----------------------------------------------------------------------------
    def log_state(self, t: float, q: Sequence[float], piston_force: float = math.nan) -> bool:
        """Log one sample (buffered; sent with ``send_columns`` every ``batch`` samples).

        The mechanism is drawn for this sample if ``1/max_draw_hz`` of simulated time passed since
        the last drawing.

        Parameters
        ----------
        t : float
            Simulated time [s], non-decreasing across calls.
        q : array_like, shape (3,)
            ``[s, psi1, psi3]`` [m, rad, rad].
        piston_force : float
            Piston force [N] (NaN if unknown: not plotted).

        Returns
        -------
        bool
            Whether the mechanism will be drawn for this sample.
        """
        if len(q) != 3:
            raise RerunLogError(f"q must hold [s, psi1, psi3], got {q!r}")
        t = float(t)
        if not math.isfinite(t):  # refused alone, rather than failing its whole batch later
            raise RerunLogError(f"t must be a finite time [s], got {t!r}")
        with self._lock:
            self._check_open()
            draw = self._last_draw is None or t - self._last_draw >= self._draw_dt - 1e-12
            n = self._n
            self._buf_q[n] = q  # first: a q that is not three numbers raises before any change
            self._buf_t[n] = t
            self._buf_f[n] = piston_force
            self._buf_draw[n] = draw
            if draw:
                self._last_draw = t
            self._n = n + 1
            if self._n >= self.batch:
                self._hand_off()
        return draw

    def _new_buffer(self) -> None:
        """Empty arrays for the next batch (the sender owns the ones handed off)."""
        self._buf_t = np.empty(self.batch)
        self._buf_q = np.empty((self.batch, 3))
        self._buf_f = np.empty(self.batch)
        self._buf_draw = np.empty(self.batch, dtype=bool)
        self._n = 0

    def _hand_off(self) -> None:
        """Queue the buffered samples to the sender (with the lock held); never waits."""
        n = self._n
        if n:
            batch = self._buf_t[:n], self._buf_q[:n], self._buf_f[:n], self._buf_draw[:n]
            self._new_buffer()
            self._sender.put(*batch)

    def _send_logged(self, t, q, force, draw) -> None:
        """The sender's work for one batch of :meth:`log_state`."""
        self._send(t, q, force, np.flatnonzero(draw))

    def flush(self) -> None:
        """Send the samples buffered by :meth:`log_state`, and wait until the sender has sent
        every batch handed to it."""
        with self._lock:
            if self._closed:
                return
            self._hand_off()
            self._sender.drain()

    def take_send_failures(self) -> list[SendFailure]:
        """The batches the sender could not send since the last call (each lost whole: its
        exception and its number of states), in order; :meth:`close` raises for those left."""
        return self._sender.take_failures()

    @property
    def send_failed(self) -> bool:
        """Whether :meth:`take_send_failures` has failures to give (cheap)."""
        return self._sender.failed

    # ---- bulk ----------------------------------------------------------------------------------
    def log_trajectory(self, t, q, piston_force=None) -> int:
        """Log a trajectory with ``send_columns`` (scalars at every sample, drawings decimated).

        Parameters
        ----------
        t : array_like, shape (n,)
            Simulated times [s], non-decreasing.
        q : array_like, shape (n, 3)
            Configurations ``[s, psi1, psi3]``.
        piston_force : array_like, shape (n,), optional
            Piston force [N] (not logged when None; NaN samples are dropped).

        Returns
        -------
        int
            Number of mechanism drawings sent.
        """
        self._check_open()  # then again under the lock: a close may come meanwhile
        t = np.asarray(t, dtype=float)
        q = np.asarray(q, dtype=float)
        if t.ndim != 1 or q.shape != (t.size, 3):
            raise RerunLogError(f"t must have shape (n,) and q (n, 3), got {t.shape} and {q.shape}")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise RerunLogError("t must be finite and non-decreasing")
        force = (
            np.full(t.size, np.nan)
            if piston_force is None
            else np.asarray(piston_force, dtype=float)
        )
        if force.shape != t.shape:
            raise RerunLogError(f"piston_force must have shape {t.shape}, got {force.shape}")
        with self._lock:
            self._check_open()
            self._hand_off()
            self._sender.drain()  # the states logged before go first
            idx = self._decimate(t)
            if idx.size:
                self._last_draw = float(t[idx[-1]])
            self._send(t, q, force, idx)  # here, not in the sender: the caller sees its errors
        return int(idx.size)

    def _send(self, t: np.ndarray, q: np.ndarray, force: np.ndarray, idx: np.ndarray) -> None:
        if t.size == 0:
            return
        rec = self.rec
        for entity, values in self._series(q, force).items():
            ok = np.isfinite(values)
            if not np.any(ok):
                continue
            rec.send_columns(
                entity,
                indexes=[rr.TimeColumn(TIMELINE, duration=t[ok])],
                columns=rr.Scalars.columns(scalars=values[ok]),
            )
            self.scalar_rows[entity] = self.scalar_rows.get(entity, 0) + int(ok.sum())
        self.sample_count += t.size
        if not idx.size:
            return
        times = [rr.TimeColumn(TIMELINE, duration=t[idx])]
        for entity, arr in self._geometry(q[idx]).items():
            color = np.tile(np.array(_COLORS[entity], dtype=np.uint8), (idx.size, 1))
            if entity == "mechanism/pins":
                cols = rr.Points2D.columns(positions=arr.reshape(-1, 2)).partition(
                    [len(PIN_NAMES)] * idx.size
                )
            else:
                # arr (n, k, 2): one strip per row; 36x faster than a list of strips
                cols = rr.LineStrips2D.columns(strips=arr, colors=color)
            rec.send_columns(entity, indexes=times, columns=cols)
        self.draw_count += idx.size

    def _decimate(self, t: np.ndarray) -> np.ndarray:
        """Indices of the samples drawn: the first, then each at least ``1/max_draw_hz`` later."""
        keep = []
        last = self._last_draw
        for i, ti in enumerate(t):  # a loop over drawings only: O(n) scalar work, no numpy calls
            if last is None or ti - last >= self._draw_dt - 1e-12:
                keep.append(i)
                last = ti
        return np.asarray(keep, dtype=int)

    # ---- lifecycle -----------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._closed:
            raise RerunLogError(f"the rerun recorder of {self._target} is closed")

    @property
    def sink_error(self) -> str | None:
        """Why the file sink failed (None: it writes, or there is no file)."""
        return None if self.sink is None else self.sink.failure

    def discard(self) -> None:
        """Drop what is not sent, close, and delete the file, if any (a node that failed to
        start)."""
        if self.sink is not None:
            self.sink.stop()
        with self._lock:
            was_open, self._closed = not self._closed, True
        self._sender.abandon()
        if was_open:
            self.rec.disconnect()
        if self.path is not None:
            self.path.unlink(missing_ok=True)

    def close(self) -> None:
        """Send what :meth:`log_state` buffered and the sender holds, join the sender, then
        flush and close the file and the live stream (idempotent). Raises
        :class:`RerunSinkError` when the file is incomplete (its end is missing): the file sink
        failed while recording or in this last flush, or the file was removed; else
        :class:`RerunLogError` when batches the sender failed to send were not taken
        (:meth:`take_send_failures`)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True  # a log_state from now on is refused, not lost
            self._hand_off()
        if self.sink is not None:
            self.sink.stop()
        try:
            self._sender.close()
        finally:
            self._close_sinks()
        unsent = _unsent(self.take_send_failures())
        if self.sink_error is not None:
            raise RerunSinkError(
                f"the rerun recording {str(self.path)!r} is incomplete, its end is missing: "
                f"{self.sink_error}" + (f"; and {unsent}" if unsent else "")
            )
        if unsent:
            raise RerunLogError(f"the rerun recording of {self._target} lacks {unsent}")

    def _close_sinks(self) -> None:
        if self.connect_url is not None:
            try:
                self.rec.flush(timeout_sec=STREAM_FLUSH_TIMEOUT_S)
            except RuntimeError as exc:  # the endpoint did not answer: the file is still whole
                self.stream_error = str(exc)
        if self.sink is not None:  # the last flush: everything sent reaches the file
            self.sink.check(math.inf, flush=self.connect_url is None)
        self.rec.disconnect()


def _unsent(failures: list[SendFailure]) -> str:
    """What ``failures`` lost, for the message of :meth:`RerunRecorder.close` ('' for none)."""
    if not failures:
        return ""
    last = failures[-1].error
    return (
        f"{sum(f.states for f in failures)} states the sender could not send "
        f"({len(failures)} batches; last: {type(last).__name__}: {last})"
    )


__all__ = [
    "DRAWINGS",
    "SERIES",
    "STREAM_FLUSH_TIMEOUT_S",
    "TIMELINE",
    "RerunRecorder",
    "RerunSinkError",
    "default_blueprint",
]
