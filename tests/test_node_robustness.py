"""The node at its edges, as its own process over real DDS: nothing a participant
sends stops it or spoils its bag, a stop is clean at any moment, its parameters are recorded as
they were in force, and its clock may jump.
"""

from __future__ import annotations

import random
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from node_support import domain_for, start_node, wait_for_file_growth

from drs_ros.client import DRSClient

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def stop_node(proc, sig=signal.SIGINT, timeout: float = 30.0) -> str:
    if proc.poll() is None:
        proc.send_signal(sig)
    try:
        out, _ = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
    return out or ""


def bag_check(bag) -> int:
    """``drs-bag check`` in this process: every byte read, then the run against the model."""
    from drs_ros.bag.cli import main

    return main(["check", str(bag)])


# (topic, message type, malformed payloads): a CDR header and one byte; a string length far
# past the end; a header only
MALFORMED = [
    ("/drs/force_cmd", "std_msgs/msg/Float64", [b"\x00\x01\x00\x00\x07", b"\x00\x01\x00\x00"]),
    ("/drs/stroke_cmd", "std_msgs/msg/Float64", [b"\x00\x01\x00\x00\x01\x02\x03"]),
    (
        "/drs/trajectory_cmd",
        "trajectory_msgs/msg/JointTrajectory",
        [
            b"\x00\x01\x00\x00" + b"\x00" * 8 + b"\xff\xff\xff\x7f" + b"x" * 8,
            b"\x00\x01\x00\x00\x01",
        ],
    ),
]


def test_malformed_bytes_on_every_command_topic_are_refused_and_kept(tmp_path, request, params):
    """Malformed bytes on each command topic and on the service's event topic: the node keeps
    publishing at rate, refuses each with the topic and the reason (effect record and
    diagnostics), keeps the bytes in the effect record, obeys a good command after them, and its
    bag passes ``drs-bag check`` and the independent readers."""
    from decoded_support import read_bag
    from rosbags.highlevel import AnyReader
    from std_msgs.msg import Float64
    from std_srvs.srv import SetBool
    from trajectory_msgs.msg import JointTrajectory

    from drs_model.kinematics import stroke_limits
    from drs_ros.bag.read.effects import effect_records

    types = {
        "std_msgs/msg/Float64": Float64,
        "trajectory_msgs/msg/JointTrajectory": JointTrajectory,
    }
    domain = domain_for(request.node.nodeid)
    bag = tmp_path / "bag"
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", "publish_rate_hz:=250.0")
    client = DRSClient(domain, keep=True, listen=("joint_states",))
    lo, hi = stroke_limits(params)
    target = lo + 0.3 * (hi - lo)
    try:
        pubs = {
            topic: client.node.create_publisher(types[t], topic, 10) for topic, t, _ in MALFORMED
        }
        evil_events = client.node.create_publisher(SetBool.Event, "/drs/drs/_service_event", 10)
        assert client.wait_for(
            lambda: (
                len(client.joint_state_msgs) > 20
                and client.commands_matched()
                and all(p.get_subscription_count() for p in pubs.values())
                and evil_events.get_subscription_count()
            )
        ), "the node did not come up"
        for topic, _t, payloads in MALFORMED:
            for data in payloads:
                pubs[topic].publish(data)  # bytes: published as they are
                client.spin(0.05)
        evil_events.publish(b"\x00\x01\x00\x00\x09\x09")
        n0 = len(client.joint_state_msgs)
        client.spin(1.0)
        rate = len(client.joint_state_msgs) - n0  # joint states in 1 s after the malformed bytes
        assert proc.poll() is None, "the node exited on malformed input"
        client.stroke(target)
        assert client.wait_for(
            lambda: abs(client.joint_state_msgs[-1].position[0] - target) < 1e-12, timeout=5.0
        ), "a good command after the malformed ones was not obeyed"
    finally:
        out = stop_node(proc)
        client.close()
    assert proc.returncode == 0, out[-3000:]
    assert rate > 125, f"{rate} joint states in 1 s at 250 Hz"

    data = read_bag(bag, ["/drs/command_events", "/diagnostics", *pubs])
    refused = [
        r for r in effect_records(data.messages["/drs/command_events"]) if r.outcome == "refused"
    ]
    for topic, _type_name, payloads in MALFORMED:
        mine = [r for r in refused if r.source == topic and r.values.get("malformed") == "true"]
        assert len(mine) == len(payloads), (topic, refused)
        for r, payload in zip(mine, payloads, strict=True):
            kept = bytes.fromhex(r.values["bytes_hex"])  # kept for forensics, as they came:
            # the transport pads a sample to a multiple of 4 bytes with zeros
            assert kept[: len(payload)] == payload and kept[len(payload) :].strip(b"\0") == b""
            assert int(r.values["size"]) == len(kept) < len(payload) + 4
        # nothing undecodable on the typed topic: only the good command there
        kept = data.messages[topic]
        assert len(kept) == (1 if topic == "/drs/stroke_cmd" else 0)
    diag = {kv.key: kv.value for kv in data.messages["/diagnostics"][-1][1].status[0].values}
    assert int(diag["refused_commands"]) == sum(len(p) for _, _, p in MALFORMED)
    # the refusal names the topic and why: in the effect record, and in diagnostics
    records = [st.message for _, m in data.messages["/drs/command_events"] for st in m.status]
    for topic, type_name, _payloads in MALFORMED:
        assert any(
            m.startswith(f"refused: {topic} '<") and f"not a valid {type_name}" in m
            for m in records
        ), (topic, records)
    diagnosed = [st.message for _, m in data.messages["/diagnostics"] for st in m.status]
    assert any(
        "refused" in m
        and "/drs/trajectory_cmd" in m
        and "not a valid trajectory_msgs/msg/JointTrajectory" in m
        for m in diagnosed
    ), diagnosed
    assert bag_check(bag) == 0
    with AnyReader([bag]) as reader:  # every message of every typed topic decodes
        conns = [c for c in reader.connections if "/srv/" not in c.msgtype]
        n = sum(1 for c, _t, raw in reader.messages(conns) if reader.deserialize(raw, c.msgtype))
    assert n > 200


def _burn(seconds: float) -> list[subprocess.Popen]:
    """Keep both cores busy for ``seconds`` (two spinning processes that end by themselves)."""
    code = f"import time\nend = time.monotonic() + {seconds}\nwhile time.monotonic() < end: pass"
    return [subprocess.Popen([sys.executable, "-c", code]) for _ in range(2)]


def test_a_stop_at_any_moment_under_load_finishes_both_recordings(tmp_path, request, params):
    """SIGINT or SIGTERM at random moments while recording at 500 Hz with a command stream
    (stroke commands and ``~/drs`` calls), both cores busy: every stop exits 0, every bag passes
    ``drs-bag check`` (metadata.yaml counts what the file holds) and every recording passes
    ``rerun rrd verify``. Before the designed stop, 1 stop in 40 ended in a segmentation fault
    and 1 demo in 12 had a miscounted bag; the 12 stops here catch a regression of that size
    with probability ~0.3 only: the benchmark ``benchmarks/shutdown_stress.py`` runs the count
    that proves it (60 stops, ``benchmarks/results/shutdown_stress.txt``). Three nodes run at
    once (one domain, one command stream for all), each stopped at its own random moment. The
    tick threads run under SCHED_OTHER here: under SCHED_FIFO, three nodes' tick threads beside
    two burners once kept a node's main thread (where the signal is handled) from ending it
    within 60 s in a fresh-clone run; that starvation is an open problem of the FIFO tick, not
    what this test is about."""

    from drs_model.kinematics import stroke_limits
    from drs_ros.recording.rerun_cli import run_rerun_cli

    batches, per_batch = 4, 3
    rng = random.Random(16)
    domain = domain_for(request.node.nodeid)
    lo, hi = stroke_limits(params)
    burners = _burn(900.0)  # killed at the end; the cap only guards a crashed test run
    client = DRSClient(domain, listen=())  # a command stream alone
    try:
        for k in range(batches):
            names = [f"b{k}_{i}" for i in range(per_batch)]
            procs = {
                name: start_node(
                    tmp_path,
                    domain,
                    f"bag_path:={tmp_path / name}",
                    f"rrd_path:={tmp_path / name}.rrd",
                    "publish_rate_hz:=500.0",
                    "flush_period:=0.1",
                    "tick_scheduling:=other",
                )
                for name in names
            }
            stops = {}
            try:
                for name in names:
                    assert wait_for_file_growth(tmp_path / name / f"{name}_0.mcap", timeout=60)
                start = time.monotonic()
                at = {name: start + 0.1 + 1.5 * rng.random() for name in names}
                while len(stops) < per_batch:  # a command stream until the last stop
                    if rng.random() < 0.25:  # a ~/drs call: its callbacks wait at the tick gate
                        client.request_drs(rng.random() < 0.5)
                    else:
                        client.stroke(lo + (hi - lo) * rng.random())
                    client.spin(0.005)
                    for name in names:
                        if name not in stops and time.monotonic() >= at[name]:
                            stops[name] = rng.choice([signal.SIGINT, signal.SIGTERM])
                            procs[name].send_signal(stops[name])
            finally:
                outs = {name: stop_node(proc, timeout=60) for name, proc in procs.items()}
            for name, proc in procs.items():
                sig = stops.get(name, signal.SIGINT).name
                assert proc.returncode == 0, f"{name}, {sig}: {outs[name][-3000:]}"
                assert bag_check(tmp_path / name) == 0, f"{name}: the bag does not verify"
                res = run_rerun_cli(["rrd", "verify", str(tmp_path / f"{name}.rrd")])
                assert res.returncode == 0, f"{name}: {res.stderr[-1000:]}"
    finally:
        client.close()
        for b in burners:
            b.kill()
            b.wait()


def test_parameters_given_are_used_and_recorded_even_at_their_defaults(tmp_path, request):
    """A file's ``Iz_wing = 0.0096`` (the value derived at the default mass) stays 0.0096 with
    ``m_wing = 3``: the recorded parameters rebuild exactly the run's DRSParams. ``-p
    model.m_wing:=2.0`` (the seed's value) against the file's 3.0 would shadow the file: refused
    at start (exit 2), naming both."""
    from decoded_support import read_bag

    from drs_model.params import DRSParams
    from drs_ros.bag.read.effects import model_params_from, recorded_node_parameters

    domain = domain_for(request.node.nodeid)
    model_file = tmp_path / "car.toml"
    model_file.write_text("m_wing = 3.0\nIz_wing = 0.0096\nL2 = 0.05\n")
    bag = tmp_path / "bag_file"
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", f"model_params_file:={model_file}")
    try:
        assert wait_for_file_growth(bag / "bag_file_0.mcap", min_size=1, timeout=60)
    finally:
        out = stop_node(proc)
    assert proc.returncode == 0, out[-2000:]
    data = read_bag(bag, ["/parameter_events"])
    recorded = recorded_node_parameters(data.messages["/parameter_events"])
    assert model_params_from(recorded) == DRSParams(m_wing=3.0, Iz_wing=0.0096)
    proc = start_node(
        tmp_path,
        domain,
        f"bag_path:={tmp_path / 'bag_given'}",
        f"model_params_file:={model_file}",
        "model.m_wing:=2.0",
    )
    try:
        proc.wait(timeout=60)  # a refusal ends it
    finally:
        out = stop_node(proc)
    assert proc.returncode == 2, out[-2000:]
    assert "model.m_wing:=2.0" in out and str(model_file) in out, out[-2000:]
    assert not (tmp_path / "bag_given").exists()


def test_a_catch_up_limit_below_two_publish_periods_is_refused_at_start(tmp_path, request):
    proc = start_node(tmp_path, domain_for(request.node.nodeid), "publish_rate_hz:=4.0")
    try:
        proc.wait(timeout=60)  # a refusal ends it
    finally:
        out = stop_node(proc)
    assert proc.returncode == 2, out[-2000:]
    assert "max_catch_up_steps 200 is below the 500 physics steps" in out


def test_a_clock_that_jumps_back_is_followed_not_frozen(tmp_path, request):
    """Under use_sim_time, ``/clock`` running forward, then stepping back 1.5 s (as a looping
    ``drs-bag play --clock`` does), then forward again: the node keeps simulating and
    publishing, stamps its states on the new clock, and records the jump."""
    from decoded_support import read_bag
    from rosgraph_msgs.msg import Clock

    from drs_ros.bag.read.effects import effect_records

    domain = domain_for(request.node.nodeid)
    bag = tmp_path / "bag"
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", "use_sim_time:=true")
    client = DRSClient(domain, keep=True, listen=("joint_states",))
    clock = client.node.create_publisher(Clock, "/clock", 10)

    def run_clock(t0_s: float, seconds: float, force_at: float) -> None:
        start, forced = time.monotonic(), False
        while (el := time.monotonic() - start) < seconds:
            ns = int((t0_s + el) * 1e9)
            msg = Clock()
            msg.clock.sec, msg.clock.nanosec = divmod(ns, 10**9)
            clock.publish(msg)
            client.spin(0.002)
            if not forced and el > 0.5:  # motion, so that a state matched to the wrong step
                client.force(force_at)  # would deviate in the re-run
                forced = True

    try:
        assert client.wait_for(
            lambda: clock.get_subscription_count() > 0 and client.commands_matched()
        )
        run_clock(1000.0, 2.0, 3000.0)
        before = len(client.joint_state_msgs)
        assert before > 50, "no joint states on /clock"
        run_clock(1000.5, 2.0, -1500.0)  # back into times already logged: log times alone mislead
        after = client.joint_state_msgs[before:]
    finally:
        out = stop_node(proc)
        client.close()
    assert proc.returncode == 0, out[-2000:]
    assert len(after) > 50, "the node froze after the clock stepped back"
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in after])
    assert 1001.5 < stamps[-1] < 1002.6  # on the new clock
    data = read_bag(bag, ["/drs/command_events"])
    jumps = [
        r
        for r in effect_records(data.messages["/drs/command_events"])
        if r.outcome == "clock" and "jump_ns" in r.values
    ]
    assert len(jumps) == 1 and "jumped back by" in out
    # from the last tick on the old clock (~1002 s) to the first on the new one (~1000.5 s)
    assert -2.5e9 < int(jumps[0].values["jump_ns"]) < -1.0e9
    # and the run re-simulates exactly across the jump (states matched to their clock origin
    # in the order the node wrote them)
    from drs_ros.bag.read.recorded_run import read_run, run_params
    from drs_ros.bag.replay.deviations import compare
    from drs_ros.bag.replay.rerun import resimulate

    run = read_run(bag)
    result = resimulate(run, run_params(run.node_parameters))
    rows = compare(
        run,
        result,
        {
            "piston_force": 1e-6,
            **dict.fromkeys(
                (
                    "stroke",
                    "link_angle",
                    "flap_angle",
                    "stroke_rate",
                    "link_rate",
                    "flap_rate",
                    "gap",
                ),
                1e-9,
            ),
        },
    )
    assert all(r["ok"] for r in rows) and not result["notes"], (rows, result["notes"])
    assert rows[0]["samples"] == run.counts["/joint_states"] > 100


def test_force_mode_at_100_hz_lands_on_the_stop_the_force_drives_to(tmp_path, request, params):
    """At the lowest allowed physics rate a +20 kN force opens the flap onto the open stop (it
    parked on the closed stop for ever before), and -5 kN from there closes it onto the closed
    stop (an IntegrationError escaped the step before, and the command was dropped)."""

    from drs_model.kinematics import stroke_limits

    domain = domain_for(request.node.nodeid)
    proc = start_node(tmp_path, domain, "physics_rate_hz:=100.0", "publish_rate_hz:=50.0")
    client = DRSClient(domain, keep=True, listen=("joint_states",))
    lo, hi = stroke_limits(params)
    try:
        assert client.wait_for(lambda: client.joint_state_msgs and client.commands_matched())
        client.force(20000.0)
        assert client.wait_for(lambda: client.stroke_now() == hi, timeout=5.0), client.stroke_now()
        client.force(-5000.0)
        assert client.wait_for(lambda: client.stroke_now() == lo, timeout=5.0), client.stroke_now()
    finally:
        out = stop_node(proc)
        client.close()
    assert proc.returncode == 0, out[-2000:]
    assert "refused" not in out


def test_a_10000_point_trajectory_is_taken_and_followed(tmp_path, request, params):
    """The largest trajectory allowed (10,000 points, a 2 Hz sine of the stroke over 5 s) is
    planned outside the real-time tick, accepted, and followed: the published strokes lie on
    the sine (the quintics through its points with the neighbours' slopes differ from it by
    ~1e-9 m), and it ends at its last point. Its cost to the loop is measured by
    ``benchmarks/node_rate.py`` (missed deadlines with a 10,000-point trajectory a second)."""
    from builtin_interfaces.msg import Duration
    from decoded_support import read_bag
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from drs_model.kinematics import stroke_limits
    from drs_ros.bag.read.effects import effect_records

    domain = domain_for(request.node.nodeid)
    bag = tmp_path / "bag"
    # 2 kHz physics: the points are 0.5 ms apart, and no segment may be shorter than a step
    dt = 1.0 / 2000.0  # physics step [s]
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", f"physics_rate_hz:={1.0 / dt}")
    client = DRSClient(domain, keep=True, listen=("joint_states",))
    lo, hi = stroke_limits(params)
    mid, amp, n, span = 0.5 * (lo + hi), 0.3 * (hi - lo), 10_000, 5.0
    t = span * np.arange(1, n + 1) / n
    s = mid + amp * np.sin(2 * np.pi * 2.0 * t)
    s[-1] = mid  # (sin(4 pi 5) = 0: it ends at rest where it started)
    msg = JointTrajectory(joint_names=["drs_piston", "drs_link", "drs_flap"])
    for tk, sk in zip(t, s, strict=True):
        sec, ns = divmod(int(round(tk * 1e9)), 10**9)
        msg.points.append(
            JointTrajectoryPoint(
                positions=[float(sk), 0.0, 0.0], time_from_start=Duration(sec=sec, nanosec=ns)
            )
        )
    try:
        assert client.wait_for(
            lambda: len(client.joint_state_msgs) > 10 and client.commands_matched()
        )
        # start at rest where the sine starts: a move there, then the trajectory
        client.stroke(mid)
        client.spin(0.5)
        client.trajectory(msg)
        client.spin(span + 1.0)
    finally:
        out = stop_node(proc)
        client.close()
    assert proc.returncode == 0, out[-2000:]
    data = read_bag(bag, ["/drs/command_events", "/joint_states"])
    records = [
        r
        for r in effect_records(data.messages["/drs/command_events"])
        if r.source == "/drs/trajectory_cmd"
    ]
    assert [r.outcome for r in records] == ["accepted"], records
    start = int(records[0].values["step"]) * dt  # sim time the trajectory started [s]
    # a state's sim time is its stamp less the clock origin in force when it was logged (a
    # loaded machine drops steps, which moves the origin)
    origins = [
        (r.log_time, int(r.values["t0_ns"]))
        for r in effect_records(data.messages["/drs/command_events"])
        if r.outcome == "clock"
    ]
    states = []
    for log, m in data.messages["/joint_states"]:
        t0 = [o for lg, o in origins if lg <= log][-1]
        sim_t = (m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - t0) * 1e-9
        states.append((sim_t, m.position[0]))
    on_path = [(ts - start, sk) for ts, sk in states if 0.2 < ts - start < span - 0.2]
    assert len(on_path) > 500
    err = max(abs(sk - (mid + amp * np.sin(2 * np.pi * 2.0 * tau))) for tau, sk in on_path)
    assert err < 1e-6, err
    assert states[-1][1] == mid
