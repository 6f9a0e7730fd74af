"""The re-simulated run written as a new bag (:func:`bag_writer`, ``drs-bag resimulate -o``)."""

from __future__ import annotations

import math
import shutil
from contextlib import contextmanager
from pathlib import Path

from drs_model.params import DRSParams
from drs_ros.bag.read.recorded_run import RecordedRun
from drs_ros.model_parameters import served_values
from drs_ros.names import TOPICS
from drs_ros.timestamps import ns_of


@contextmanager
def bag_writer(out: str | Path, run: RecordedRun, models: tuple[DRSParams, object], rung: str):
    """The re-simulated run as a new bag, written as :func:`.deviations.compare` goes (its
    ``on_state``): the parameters it ran with, then joint states, force, gap and acceleration
    at the recorded stamps (so ``drs-bag check`` checks it too). ``models``: the re-run's
    DRSParams and HydraulicParams. Nothing is left of it if the re-run fails."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rcl_interfaces.msg import ParameterEvent
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from drs_ros.bag.read.effects import parameter_event
    from drs_ros.conversions import command_event_msg, float_msg, time_msg
    from drs_ros.recording.mcap_recorder import McapRecorder

    names = list(run.node_parameters["joint_names"])
    tp = run.topics
    values = dict(run.node_parameters)
    values.update(served_values(*models))  # as the node records them
    values["fidelity"] = rung  # the rung it ran on (--fidelity)
    made = not Path(out).exists()
    rec = McapRecorder(out, flush_thread=False)
    first = [True]

    def write(log: int, m, state) -> None:
        if first[0]:  # the parameters, at the first joint state's log time
            first[0] = False
            rec.register_topic(tp["parameter_events"], ParameterEvent, 1000)
            rec.write(tp["parameter_events"], parameter_event(run.node, values, log), log)
            # the node's name and the topics written, as a node's topics record gives them
            written = {
                k: tp[k]
                for k in (
                    "joint_states",
                    "piston_force",
                    "flap_gap",
                    "piston_acceleration",
                    "parameter_events",
                    "command_events",
                )
            }
            rec.register_topic(tp["command_events"], DiagnosticArray, 100)
            record = command_event_msg(
                log, TOPICS, TOPICS, DiagnosticStatus.OK, "", {"node": run.node, **written}
            )
            rec.write(tp["command_events"], record, log)
            rec.register_topic(tp["joint_states"], JointState, 10)
            for key in ("piston_force", "flap_gap", "piston_acceleration"):
                rec.register_topic(tp[key], Float64, 10)
        if state is None:
            return
        q, qd, force, gap, acc = state
        js = JointState(
            name=names,
            position=[float(x) for x in q],
            velocity=[float(x) for x in qd],
            effort=[float(force), math.nan, math.nan],
        )
        js.header.stamp = time_msg(ns_of(m.header.stamp))
        rec.write(tp["joint_states"], js, log)
        rec.write(tp["piston_force"], float_msg(force), log)
        rec.write(tp["flap_gap"], float_msg(gap), log)
        rec.write(tp["piston_acceleration"], float_msg(acc), log)

    try:
        yield write
    except BaseException:
        rec.discard()
        if made:
            shutil.rmtree(out, ignore_errors=True)
        raise
    if first[0]:  # no joint state: the parameters alone
        write(0, None, None)
    rec.finish()


__all__ = ["bag_writer"]
