"""The node's recordings: the rosbag2 MCAP bag (every message as its exact bytes) and the rerun
recording (a file, a live viewer, or both).

Both paths are checked before anything is created, and a node that fails to start leaves nothing
behind; a recording that fails (a full disk) stops recording, not the actuator, and says so in
diagnostics; both are finished when the node stops.

:class:`NodeRecordings` is a part of :class:`drs_ros.node.adapter.DRSNode` (its methods read the
node's parameters and log through it); it holds the recorders.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from drs_model.errors import DRSError

from ..errors import DRSRosError


class NodeRecordings:
    """The bag and the rerun recording of the DRS node (a base class of ``DRSNode``)."""

    def _open_recordings(self) -> None:
        """Check both paths, then create both recorders; on any failure remove what was made."""
        from ..recording.errors import RecordingError
        from ..recording.mcap_recorder import McapRecorder, check_new_bag

        self.recording_error = ""

        bag = self.get_parameter("bag_path").value
        rrd = self.get_parameter("rrd_path").value
        live = self.get_parameter("rerun_connect").value
        if bag:
            check_new_bag(bag)
        if rrd or live:
            from ..recording.rerun_recorder import check_connect_url, check_new_rrd

            if rrd:
                check_new_rrd(rrd)
            if live:
                check_connect_url(live)
        made_dir = bool(bag) and not Path(bag).exists()
        try:
            if bag:
                self.recorder = McapRecorder(
                    bag, flush_period=self.get_parameter("flush_period").value
                )
            if rrd or live:
                from ..recording.rerun_recorder import RerunRecorder

                # the mechanism drawn as often as ~/markers draws it; the series at every sample
                self.rerun = RerunRecorder(
                    rrd or None,
                    self.params,
                    connect_url=live or None,
                    max_draw_hz=self.markers_rate_hz,
                )
        except Exception as exc:
            self._made_bag_dir = made_dir
            self.discard_recordings()
            if isinstance(exc, (DRSError, DRSRosError)):  # ours: its message says it all
                raise
            raise RecordingError(f"cannot start the recordings: {exc}") from exc
        self._made_bag_dir = made_dir

    def discard_recordings(self) -> None:
        """Close and delete the recordings of a node that fails to start: nothing is left."""
        if self.recorder is not None:
            self.recorder.discard()
            if self._made_bag_dir:
                shutil.rmtree(self.recorder.bag_dir, ignore_errors=True)
            self.recorder = None
        if self.rerun is not None:
            self.rerun.discard()
            self.rerun = None

    def _record(self, topic: str, data: bytes, now_ns: int) -> int | None:
        """Append exact bytes to the bag; returns the sequence number (None: not recorded)."""
        if self.recorder is None or self.recording_error:
            return None
        try:
            return self.recorder.write(topic, data, log_time_ns=now_ns)
        except Exception as exc:  # noqa: BLE001 - a failing disk must not stop the actuator
            self.recording_error = f"{type(exc).__name__}: {exc}"
            self.get_logger().error(f"recording stopped: {self.recording_error}")
            return None

    def close_recordings(self) -> None:
        """Finish the MCAP bag and the rerun file (idempotent)."""
        if self.rerun is not None:
            try:
                self.rerun.close()
            except Exception as exc:  # noqa: BLE001
                self.get_logger().error(f"rerun close failed: {exc}")
        if self.recorder is not None:
            try:
                self.recorder.finish()
            except Exception as exc:  # noqa: BLE001
                self.get_logger().error(f"bag finish failed: {exc}")


__all__ = ["NodeRecordings"]
