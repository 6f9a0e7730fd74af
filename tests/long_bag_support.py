"""A test fixture: long bags made to measure the bag tools: the seed manoeuvre recorded over
and over, as the node records it, to any size.

:func:`write_long_bag` writes a rosbag2 bag directory (MCAP, ``metadata.yaml``) of ``cycles``
manoeuvres back to back at 1 kHz: ``/joint_states`` (positions, velocities and the piston force
of the model, header stamps), ``/drs/flap_gap``, ``/drs/piston_force`` and
``/drs/piston_acceleration``, logged at the stamps, and the model parameters on
``/parameter_events`` first. Each sample is serialised once; later cycles copy its bytes with a
new stamp, so a gigabyte takes about a minute. ``drs-bag check`` passes on it: the states are the
model's own (:func:`drs_model.kinematics.kinematic_state` of
:func:`drs_model.profile.drs_manoeuvre`, the force from
:func:`drs_model.inverse.inverse_dynamics`). ``bulk_bytes`` adds a topic of large messages
(``/camera/image_raw``, ``sensor_msgs/msg/Image``, once per cycle) as a camera would, which the
checks read and verify but do not decode into their tables.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from drs_model.params import NUMERIC_FIELDS, DRSParams
from drs_ros.names import DEFAULT_JOINT_NAMES, DEFAULT_TOPICS
from drs_ros.timestamps import T0_NS, ns_from_seconds, split_ns

#: Sample period of the recorded states [s] (the node's default publish rate is lower; 1 kHz is
#: its physics rate).
SAMPLE_PERIOD_S = 1e-3
BULK_TOPIC = "/camera/image_raw"


def cycle_samples(params: DRSParams) -> dict[str, np.ndarray]:
    """One manoeuvre sampled every :data:`SAMPLE_PERIOD_S` (its last sample left out: the next
    cycle starts there): times [s], ``q``, ``qd``, piston force [N], gap [m], piston
    acceleration [m/s^2]."""
    from drs_model.inverse import inverse_dynamics
    from drs_model.kinematics import gap, kinematic_state
    from drs_model.profile import drs_manoeuvre

    man = drs_manoeuvre(params)
    t = np.arange(0.0, man.t_end - 0.5 * SAMPLE_PERIOD_S, SAMPLE_PERIOD_S)
    s, v, a = man.evaluate(t)
    state = kinematic_state(s, v, a, params)
    force = inverse_dynamics((state.q, state.qd, state.qdd), params).piston_force
    return {
        "t": t,
        "q": state.q,
        "qd": state.qd,
        "force": np.asarray(force, dtype=float),
        "gap": np.asarray(gap(state.q, params), dtype=float),
        "accel": np.asarray(a),
    }


def write_long_bag(
    bag_dir: str | Path,
    cycles: int,
    *,
    params: DRSParams | None = None,
    bulk_bytes: int = 0,
    compression: str = "none",
    chunk_size: int = 1024 * 1024,
) -> Path:
    """Write ``cycles`` manoeuvres (see the module docstring) into the new bag directory
    ``bag_dir``; returns it. ``compression``: ``none``, ``lz4`` or ``zstd`` chunks."""
    from rcl_interfaces.msg import ParameterEvent
    from sensor_msgs.msg import Image, JointState
    from std_msgs.msg import Float64

    from drs_ros.bag.read.effects import parameter_event
    from drs_ros.conversions import float_msg
    from drs_ros.recording import cdr
    from drs_ros.recording.mcap_recorder import McapRecorder

    p = params if params is not None else DRSParams()
    samples = cycle_samples(p)
    n = len(samples["t"])
    period_ns = ns_from_seconds(n * SAMPLE_PERIOD_S)
    tp = DEFAULT_TOPICS
    states, scalars = [], []
    for i in range(n):
        js = JointState(
            name=list(DEFAULT_JOINT_NAMES),
            position=[float(x) for x in samples["q"][i]],
            velocity=[float(x) for x in samples["qd"][i]],
            effort=[float(samples["force"][i]), np.nan, np.nan],
        )
        states.append(bytearray(cdr.serializer(JointState)(js)))
        scalars.append(
            [
                (tp[key], cdr.serializer(Float64)(float_msg(float(samples[name][i]))))
                for key, name in (
                    ("flap_gap", "gap"),
                    ("piston_force", "force"),
                    ("piston_acceleration", "accel"),
                )
            ]
        )
    offsets = [ns_from_seconds(t) for t in samples["t"]]
    bulk = None
    if bulk_bytes > 0:
        image = Image(
            height=1,
            width=int(bulk_bytes),
            encoding="mono8",
            step=int(bulk_bytes),
            data=bytes(int(bulk_bytes)),
        )
        bulk = bytearray(cdr.serializer(Image)(image))
    with McapRecorder(
        bag_dir, flush_thread=False, compression=compression, chunk_size=chunk_size
    ) as rec:
        rec.register_topic(tp["parameter_events"], ParameterEvent, 1000)
        values = {f"model.{k}": float(getattr(p, k)) for k in NUMERIC_FIELDS}
        rec.write(tp["parameter_events"], parameter_event("/drs", values, T0_NS), T0_NS)
        rec.register_topic(tp["joint_states"], JointState, 10)
        for key in ("flap_gap", "piston_force", "piston_acceleration"):
            rec.register_topic(tp[key], Float64, 10)
        if bulk is not None:
            rec.register_topic(BULK_TOPIC, Image, 10)
        for c in range(cycles):
            start = T0_NS + 1_000_000 + c * period_ns
            for i in range(n):
                ns = start + offsets[i]
                data = states[i]
                struct.pack_into("<iI", data, 4, *split_ns(ns))  # header.stamp
                rec.write(tp["joint_states"], data, ns)
                for topic, value in scalars[i]:
                    rec.write(topic, value, ns)
            if bulk is not None:
                struct.pack_into("<iI", bulk, 4, *split_ns(start))
                rec.write(BULK_TOPIC, bulk, start)
    return Path(bag_dir)


__all__ = ["BULK_TOPIC", "T0_NS", "cycle_samples", "write_long_bag"]
