"""``drs-node --managed`` driven through its lifecycle by a second process over real DDS: each
configure records anew (``bag_path``, then ``bag_path_1``, ``_2``, ...; the ``.rrd`` likewise),
each cycle's bag and recording are complete and hold that cycle's run only, a path that exists
is refused (the transition fails, the node lives on), and every problem of every cycle reaches
the exit status (docs/cli.md)."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from node_support import domain_for, start_node, wait_for_file_growth
from ros_support import require_rclpy

pytestmark = [pytest.mark.ros, pytest.mark.slow]

require_rclpy()

from lifecycle_msgs.msg import State, Transition  # noqa: E402
from lifecycle_msgs.srv import ChangeState, GetState  # noqa: E402
from test_node_robustness import bag_check, stop_node  # noqa: E402

from drs_model.kinematics import stroke_limits  # noqa: E402
from drs_ros.client import DRSClient  # noqa: E402
from drs_ros.recording.rerun_cli import run_rerun_cli  # noqa: E402

MANAGED = [sys.executable, "-m", "drs_ros", "--managed"]


class LifecycleManager:
    """The lifecycle services of the node ``/drs``, called from a :class:`DRSClient`'s node."""

    def __init__(self, client: DRSClient) -> None:
        self.client = client
        self.change = client.node.create_client(ChangeState, "/drs/change_state")
        self.get = client.node.create_client(GetState, "/drs/get_state")
        assert self.change.wait_for_service(timeout_sec=60.0), "no /drs/change_state"

    def _call(self, service, request):
        fut = service.call_async(request)
        assert self.client.wait_for(fut.done, timeout=60.0), "the lifecycle service did not answer"
        return fut.result()

    def state(self) -> int:
        return self._call(self.get, GetState.Request()).current_state.id

    def transition(self, transition_id: int) -> bool:
        request = ChangeState.Request()
        request.transition.id = transition_id
        return self._call(self.change, request).success


def run_cycle(manager: LifecycleManager, client: DRSClient, target: float, during=None) -> None:
    """configure, activate, move to ``target`` [m] (:func:`start_cycle`), ``during()``,
    deactivate, cleanup."""
    start_cycle(manager, client, target)
    if during is not None:
        during()
    assert manager.transition(Transition.TRANSITION_DEACTIVATE)
    assert manager.transition(Transition.TRANSITION_CLEANUP)
    assert manager.state() == State.PRIMARY_STATE_UNCONFIGURED


def start_cycle(manager: LifecycleManager, client: DRSClient, target: float) -> None:
    """configure, activate, move to ``target`` [m] (the command sent again until the joint
    states reach it: a command sent before the new subscription is matched is lost) and hold
    there for a while."""
    assert manager.transition(Transition.TRANSITION_CONFIGURE)
    assert manager.transition(Transition.TRANSITION_ACTIVATE)
    assert manager.state() == State.PRIMARY_STATE_ACTIVE
    client.joint_state_msgs.clear()

    def reached() -> bool:
        return bool(client.joint_state_msgs) and abs(client.stroke_now() - target) < 1e-12

    for _ in range(30):
        client.stroke(target)
        if client.wait_for(reached, timeout=2.0):
            break
    assert reached(), f"the node did not reach {target} m (last {client.stroke_now()} m)"
    client.spin(0.5)  # held there: a run of some hundred states (the motion takes 10 ms)


def bag_strokes(bag: Path) -> tuple[list[float], list[float]]:
    """The stroke commands (rosbags) and the joint states' piston strokes (mcap_ros2) of
    ``bag``: two readers we did not write."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic == "/drs/stroke_cmd"]
        commands = [
            reader.deserialize(raw, c.msgtype).data
            for c, _, raw in reader.messages(connections=conns)
        ]
    with open(bag / f"{bag.name}_0.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        strokes = [
            m.position[0] for _, _, _, m in reader.iter_decoded_messages(topics=["/joint_states"])
        ]
    return commands, strokes


def rrd_strokes(rrd: Path) -> list[tuple[int, float]]:
    """The rerun recording's stroke series: ``(simulated time [ns], stroke [m])`` in time
    order, read with rerun's own reader."""
    from rerun.chunk import RrdReader

    rows = []
    for chunk in RrdReader(str(rrd)).stream().to_chunks():
        batch = chunk.to_record_batch()
        if str(chunk.entity_path) == "/series/stroke" and "sim_time" in batch.schema.names:
            times = batch.column("sim_time").cast("int64").to_pylist()
            rows += [
                (t, v[0])
                for t, v in zip(times, batch.column("Scalars:scalars").to_pylist(), strict=True)
            ]
    return sorted(rows)


def assert_cycle_recorded(bag: Path, rrd: Path, target: float, lo: float) -> None:
    """``bag`` passes ``drs-bag check`` and holds its own cycle only: its commands, and a run
    from rest at ``lo`` [m] to ``target`` [m] (rosbags, mcap_ros2); ``rrd`` verifies (rerun's
    own CLI) and holds the same run (rerun's reader)."""
    assert bag_check(bag) == 0, bag
    commands, strokes = bag_strokes(bag)
    assert commands and set(commands) == {target}, (bag, commands)
    assert len(strokes) > 50 and strokes[0] == pytest.approx(lo, abs=1e-12)
    assert strokes[-1] == pytest.approx(target, abs=1e-12)
    assert max(strokes) == pytest.approx(target, abs=1e-9)  # no other cycle's motion
    verify = run_rerun_cli(["rrd", "verify", str(rrd)])
    assert verify.returncode == 0, (rrd, verify.stderr[-1000:])
    series = rrd_strokes(rrd)
    assert series[0] == (0, pytest.approx(lo, abs=1e-12)), (rrd, series[:3])
    assert series[-1][1] == pytest.approx(target, abs=1e-12), (rrd, series[-3:])
    assert max(v for _, v in series) == pytest.approx(target, abs=1e-9)


def targets(params, n: int) -> list[float]:
    """``n`` strokes [m], rising, within the travel: one for each cycle."""
    lo, hi = stroke_limits(params)
    return [float(s) for s in lo + (hi - lo) * np.linspace(0.2, 0.8, n)]


def test_five_cycles_record_five_complete_bags_and_recordings(tmp_path, request, params):
    """configure, activate, command, deactivate, cleanup five times with a bag and an .rrd,
    then shutdown: five bags and five .rrd under the cycle's names, each complete (``drs-bag
    check``, rosbags, mcap_ros2, ``rerun rrd verify``) and holding its own cycle's run; exit 0
    and no line of an incomplete recording."""
    domain = domain_for(request.node.nodeid)
    bag, rrd = tmp_path / "bag", tmp_path / "run.rrd"
    strokes = targets(params, 5)
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", f"rrd_path:={rrd}", argv=MANAGED)
    client = DRSClient(domain, keep=True, listen=("joint_states",), timeout=60.0)
    try:
        manager = LifecycleManager(client)
        assert manager.state() == State.PRIMARY_STATE_UNCONFIGURED
        for target in strokes:
            run_cycle(manager, client, target)
        assert manager.transition(Transition.TRANSITION_UNCONFIGURED_SHUTDOWN)
        assert manager.state() == State.PRIMARY_STATE_FINALIZED
    finally:
        client.close()
        out = stop_node(proc)
    assert proc.returncode == 0, out[-3000:]
    assert "incomplete" not in out and "refused" not in out, out[-3000:]
    bags = [bag] + [tmp_path / f"bag_{n}" for n in range(1, 5)]
    rrds = [rrd] + [tmp_path / f"run_{n}.rrd" for n in range(1, 5)]
    assert sorted(
        p.name for p in tmp_path.iterdir() if p.name.startswith(("bag", "run"))
    ) == sorted(p.name for p in bags + rrds)
    for b, r, target in zip(bags, rrds, strokes, strict=True):
        assert_cycle_recorded(b, r, target, stroke_limits(params)[0])


def test_a_stop_in_a_later_cycle_finishes_its_recordings(tmp_path, request, params):
    """SIGINT while the second cycle is active: ``drs-node`` finishes that cycle's bag and
    .rrd as a stop of the unmanaged node does, exits 0, and both cycles' recordings are
    complete, each its own run."""
    domain = domain_for(request.node.nodeid)
    bag, rrd = tmp_path / "bag", tmp_path / "run.rrd"
    strokes = targets(params, 2)
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", f"rrd_path:={rrd}", argv=MANAGED)
    client = DRSClient(domain, keep=True, listen=("joint_states",), timeout=60.0)
    try:
        manager = LifecycleManager(client)
        run_cycle(manager, client, strokes[0])
        start_cycle(manager, client, strokes[1])
    finally:
        client.close()
        out = stop_node(proc)
    assert proc.returncode == 0, out[-3000:]
    assert "drs-node: stopped by SIGINT, recordings finished" in out, out[-3000:]
    assert_cycle_recorded(bag, rrd, strokes[0], stroke_limits(params)[0])
    assert_cycle_recorded(
        tmp_path / "bag_1", tmp_path / "run_1.rrd", strokes[1], stroke_limits(params)[0]
    )


def test_a_bag_lost_in_one_cycle_reaches_the_exit_status(tmp_path, request, params):
    """The second cycle's bag directory removed while it records: the node goes on, the third
    cycle records to its own name, and at the stop ``drs-node`` exits 1 naming the second
    cycle's bag (an earlier cycle's problem is not forgotten); the other bags are complete."""
    domain = domain_for(request.node.nodeid)
    bag, rrd = tmp_path / "bag", tmp_path / "run.rrd"
    lost = tmp_path / "bag_1"
    strokes = targets(params, 3)
    proc = start_node(
        tmp_path, domain, f"bag_path:={bag}", f"rrd_path:={rrd}", "flush_period:=0.2", argv=MANAGED
    )
    client = DRSClient(domain, keep=True, listen=("joint_states",), timeout=60.0)

    def remove_the_bag() -> None:
        assert wait_for_file_growth(lost / "bag_1_0.mcap", timeout=60, min_size=20_000)
        shutil.rmtree(lost)
        client.spin(1.0)  # a flush or more after the removal, mostly

    try:
        manager = LifecycleManager(client)
        run_cycle(manager, client, strokes[0])
        run_cycle(manager, client, strokes[1], during=remove_the_bag)
        run_cycle(manager, client, strokes[2])
    finally:
        client.close()
        out = stop_node(proc)
    assert proc.returncode == 1, out[-3000:]
    # "is lost" once a flush saw it, "is incomplete" when the cleanup's finish was first
    line = next((x for x in out.splitlines() if x.startswith(f"drs-node: bag '{lost}' is ")), "")
    assert "removed while recording" in line, out[-3000:]
    assert "recordings incomplete" in out
    assert not lost.exists()
    for b, r, target in (
        (bag, rrd, strokes[0]),
        (tmp_path / "bag_2", tmp_path / "run_2.rrd", strokes[2]),
    ):
        assert_cycle_recorded(b, r, target, stroke_limits(params)[0])
    verify = run_rerun_cli(["rrd", "verify", str(tmp_path / "run_1.rrd")])
    assert verify.returncode == 0, verify.stderr[-1000:]  # the bag's loss is the bag's only


def test_a_later_cycle_never_overwrites_and_its_refusal_reaches_the_exit_status(
    tmp_path, request, params
):
    """The second configure's bag path exists (a directory holding a file): that configure
    fails with the reason, the node stays alive and unconfigured and the file is untouched;
    once it is moved away the next configure records to that name (a refused configure takes
    no number). At the stop ``drs-node`` names the refusal and exits 2."""
    domain = domain_for(request.node.nodeid)
    bag = tmp_path / "bag"
    taken = tmp_path / "bag_1"
    taken.mkdir()
    (taken / "notes.txt").write_text("an earlier recording")
    strokes = targets(params, 2)
    proc = start_node(tmp_path, domain, f"bag_path:={bag}", argv=MANAGED)
    client = DRSClient(domain, keep=True, listen=("joint_states",), timeout=60.0)
    try:
        manager = LifecycleManager(client)
        run_cycle(manager, client, strokes[0])
        assert not manager.transition(Transition.TRANSITION_CONFIGURE)
        assert manager.state() == State.PRIMARY_STATE_UNCONFIGURED
        assert proc.poll() is None
        assert sorted(p.name for p in taken.iterdir()) == ["notes.txt"]
        assert (taken / "notes.txt").read_text() == "an earlier recording"
        shutil.move(taken, tmp_path / "moved")
        run_cycle(manager, client, strokes[1])
    finally:
        client.close()
        out = stop_node(proc)
    assert proc.returncode == 2, out[-3000:]
    assert f"drs-node: configure refused: bag path '{taken}' already holds files" in out, out[
        -3000:
    ]
    assert "configure 2 of this node records to bag_path and rrd_path with _1 appended" in out
    assert bag_check(bag) == 0 and bag_check(taken) == 0
    assert set(bag_strokes(taken)[0]) == {strokes[1]}
    assert (tmp_path / "moved" / "notes.txt").read_text() == "an earlier recording"
