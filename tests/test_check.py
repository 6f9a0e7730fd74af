"""drs-check: consistent bags pass, corrupted states fail, broken files get a clear message."""

from __future__ import annotations

import json

import numpy as np
import pytest
from decoded_support import check_bag, read_bag
from ros_support import JOINT_NAMES, require_rclpy, write_drs_bag

from drs_ros.bag.check import command as check
from drs_ros.bag.check import model_checks
from drs_ros.bag.read.files import BagReadError

pytestmark = pytest.mark.ros


@pytest.fixture
def good_bag(tmp_path, params):
    require_rclpy()
    rec, *_ = write_drs_bag(tmp_path / "good", params, n=150)
    return rec


def test_consistent_bag_passes(good_bag, capsys):
    assert check.main([str(good_bag.bag_dir), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["ok"] and not report["recovered"]
    assert report["messages"]["/joint_states"] == 150
    by_name = {c["name"]: c for c in report["checks"]}
    assert by_name["loop constraint |Phi(q)|"]["max_error"] < 1e-9
    assert by_name["velocity constraint |Phi_q qd|"]["samples"] == 150
    assert by_name["gap vs kinematics.gap(q)"]["status"] == "ok"
    model = by_name["piston force vs model"]
    hook, _ = model_checks.load_force_model()
    assert hook is not None  # drs_model.inverse provides it
    # reported, not enforced without --force-model-tol
    assert model["status"] == "info" and model["samples"] == 150


def test_corrupted_joint_state_fails_with_the_discrepancy(tmp_path, params, capsys):
    require_rclpy()
    delta = 2e-4
    rec, t, q, *_ = write_drs_bag(tmp_path / "bad", params, n=150, corrupt=(37, 2, delta))
    assert check.main([str(rec.path), "--tol", "1e-6"]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out
    data = read_bag(rec.path, ["/joint_states", "/drs/piston_force", "/drs/flap_gap"])
    results = {r.name: r for r in check_bag(data, params, tol=1e-6)}
    loop = results["loop constraint |Phi(q)|"]
    assert loop.status == "FAIL"
    assert loop.at_time_s == pytest.approx(1.7e9 + t[37], abs=1e-6)
    # a flap-angle error delta moves C3 by L3 delta (-sin psi3, cos psi3) to first order
    psi3 = q[37, 2]
    first_order = params.L3 * delta * max(abs(np.sin(psi3)), abs(np.cos(psi3)))
    assert loop.max_error == pytest.approx(first_order, rel=1e-2)
    gap = results["gap vs kinematics.gap(q)"]
    assert gap.status == "FAIL"
    assert gap.max_error == pytest.approx(params.tip_arm * delta * abs(np.cos(psi3)), rel=1e-2)


def test_custom_topics_and_force_hook(tmp_path, params):
    require_rclpy()
    rec, t, q, qd, force = write_drs_bag(tmp_path / "hook", params, n=60)
    data = read_bag(rec.bag_dir, ["/joint_states"])

    def fake_model(q, qd, qdd, p):
        return np.zeros(len(q))

    results = check_bag(data, params, force_model=fake_model, force_model_tol=1.0)
    model = next(r for r in results if r.name == "piston force vs model")
    assert model.status == "FAIL" and model.max_error == pytest.approx(np.max(np.abs(force)))
    with pytest.raises(model_checks.ForceModelError, match="cannot load force model"):
        model_checks.load_force_model("drs_model:no_such_function")


def test_truncated_file_message_and_recover(good_bag, capsys):
    raw = good_bag.path.read_bytes()
    cut = good_bag.path.parent / "cut.mcap"
    cut.write_bytes(raw[: int(len(raw) * 0.6)])
    assert check.main([str(cut)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "truncated" in err and "drs-bag recover" in err
    with pytest.raises(BagReadError, match="truncated"):
        read_bag(cut, ["/joint_states"])
    # this bag is one chunk (no flush before finish): its cut leaves no complete chunk
    assert check.main([str(cut), "--recover"]) == 2
    assert "nothing recoverable" in capsys.readouterr().err


def test_recover_reads_the_prefix_of_a_chunked_bag(tmp_path, params, capsys):
    require_rclpy()
    rec, t, q, *_ = write_drs_bag(
        tmp_path / "chunks", params, n=200, recorder_kwargs={"flush_messages": 60}
    )
    raw = rec.path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(raw[: len(raw) // 2])
    data = read_bag(cut, ["/joint_states"], recover=True)
    js = data.messages["/joint_states"]
    assert 0 < len(js) < 200
    np.testing.assert_array_equal(np.array([m.position for _, m in js]), q[: len(js)])
    results = check_bag(data, params)
    assert results[0].status == "ok" and results[0].samples == len(js)
    # a damaged bag checked in part has an exit status of its own (3), never 0
    assert check.main([str(cut), "--recover", "--json"]) == check.EXIT_RECOVERED == 3
    report = json.loads(capsys.readouterr().out)
    assert report["recovered"] and report["messages"]["/joint_states"] == len(js)
    assert any(note.startswith("stopped at offset") for note in report["notes"])


def test_garbage_and_missing_files(tmp_path, capsys):
    require_rclpy()  # the ros extra brings mcap and mcap_ros2
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not an mcap file at all" * 10)
    assert check.main([str(junk)]) == 2
    assert "not an MCAP file" in capsys.readouterr().err
    assert check.main([str(junk), "--recover"]) == 2
    assert "not an MCAP file" in capsys.readouterr().err
    with pytest.raises(BagReadError, match="no such bag file or directory"):
        read_bag(tmp_path / "nope", ["/joint_states"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(BagReadError, match="no metadata.yaml"):
        read_bag(tmp_path / "empty", ["/joint_states"])
    with pytest.raises(SystemExit) as exc:  # an option, not the bag: argparse's usage error
        check.main([str(junk), "--joint-names", "a,b"])
    assert exc.value.code == 2
    assert "argument --joint-names: needs 3 names" in capsys.readouterr().err


def test_a_nan_joint_state_fails_its_row_and_the_rest_is_still_checked(tmp_path, params, capsys):
    require_rclpy()
    write_drs_bag(tmp_path / "nan", params, n=60, corrupt=(30, 2, float("nan")))
    assert check.main([str(tmp_path / "nan"), "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    rows = {c["name"]: c for c in report["checks"]}
    assert rows["finite joint states"]["status"] == "FAIL"
    assert rows["finite joint states"]["max_error"] == 1.0
    assert rows["gap vs kinematics.gap(q)"]["samples"] >= 59  # the other samples still checked
    assert rows["piston force vs model"]["status"] == "info"


def _actuator_bag(bag_dir, params, corrupt_at=None):
    """Record an ActuatorSim run as the node does (joint states, force, gap, acceleration):
    the seed's opening, a force step onto the open stop, then 100 N (below the 322 N that holds
    it open: the flap falls back)."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from drs_model.actuator import ActuatorSim
    from drs_ros.recording.mcap_recorder import McapRecorder

    a = ActuatorSim(params, dt=1e-4)
    t0 = 1_700_000_000_000_000_000
    with McapRecorder(bag_dir, flush_thread=False) as rec:
        for topic in ("/drs/piston_force", "/drs/flap_gap", "/drs/piston_acceleration"):
            rec.register_topic(topic, Float64, 10)
        rec.register_topic("/joint_states", JointState, 10)
        plan = {
            0: lambda: a.command_drs(True),
            200: lambda: a.command_force(2500.0),
            300: lambda: a.command_force(100.0),
        }
        for k in range(500):
            if k in plan:
                plan[k]()
            st = a.step()
            ns = t0 + int(round(st.t * 1e9))
            msg = JointState(
                name=list(JOINT_NAMES),
                position=[float(x) for x in st.q],
                velocity=[float(x) for x in st.qd],
                effort=[st.piston_force, float("nan"), float("nan")],
            )
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
            force = st.piston_force + (5.0 if k == corrupt_at else 0.0)
            msg.effort[0] = force
            rec.write("/joint_states", msg, ns)
            rec.write("/drs/piston_force", Float64(data=force), ns)
            rec.write("/drs/flap_gap", Float64(data=st.gap), ns)
            rec.write("/drs/piston_acceleration", Float64(data=float(st.qdd[0])), ns)
    return a


def test_logged_acceleration_replays_the_piston_force_exactly(tmp_path, params, capsys):
    """Stroke mode (inverse dynamics) and force mode (forward dynamics) both invert back to the
    logged force; a 5 N error on one sample fails the check."""
    require_rclpy()
    a = _actuator_bag(tmp_path / "good", params)
    assert a.state.at_stop is None or a.state.at_stop == "closed"
    assert check.main([str(tmp_path / "good"), "--json", "--force-tol", "1e-3"]) == 0
    rows = {c["name"]: c for c in json.loads(capsys.readouterr().out)["checks"]}
    row = rows["piston force vs model, logged accel."]
    # the samples resting on the open stop after the opening (exactly at rest there) are left out
    assert row["status"] == "ok" and row["samples"] > 250 and row["max_error"] < 1e-3
    _actuator_bag(tmp_path / "bad", params, corrupt_at=50)  # mid-opening
    assert check.main([str(tmp_path / "bad"), "--json", "--force-tol", "1e-3"]) == 1
    rows = {c["name"]: c for c in json.loads(capsys.readouterr().out)["checks"]}
    assert rows["piston force vs model, logged accel."]["max_error"] == pytest.approx(5.0, rel=1e-6)


@pytest.mark.parametrize("block", [1, 2, 7, 64])
def test_checks_block_by_block_equal_the_checks_over_the_whole_bag(tmp_path, params, block):
    """A streaming check (blocks of a few joint states, each with its neighbours) gives what the
    checks give over every sample at once (one block), on both force paths: the logged
    acceleration and the finite differences."""
    require_rclpy()
    from long_bag_support import write_long_bag

    bag = write_long_bag(tmp_path / "long", 3, params=params)
    topics = ["/joint_states", "/drs/flap_gap", "/drs/piston_acceleration"]
    data = read_bag(bag, topics)
    hook, note = model_checks.load_force_model()
    for without in (None, "/drs/piston_acceleration"):
        if without:
            data.messages.pop(without)
        whole = check_bag(data, params, force_model=hook, force_note=note, block_states=10**9)
        blocks = check_bag(data, params, force_model=hook, force_note=note, block_states=block)
        assert [r.name for r in whole][-1].startswith("piston force vs model")
        assert whole[-1].samples > 0
        for a, b in zip(whole, blocks, strict=True):
            assert (a.name, a.samples, a.status, a.note) == (b.name, b.samples, b.status, b.note)
            np.testing.assert_array_equal([a.max_error, a.at_time_s], [b.max_error, b.at_time_s])


@pytest.mark.parametrize("compression", ["lz4", "zstd"])
def test_compressed_chunks_are_checked(tmp_path, params, compression, capsys):
    """Chunks compressed with lz4 or zstd (the lz4 and zstandard dependencies) read and pass; a
    flipped byte inside a compressed chunk is caught (its CRC or its decompression)."""
    require_rclpy()
    from long_bag_support import write_long_bag

    bag = write_long_bag(
        tmp_path / compression, 4, params=params, compression=compression, chunk_size=4096
    )
    assert check.main([str(bag), "--json"]) == check.EXIT_OK
    report = json.loads(capsys.readouterr().out)
    assert report["messages"]["/joint_states"] == 4 * 50
    mcap_file = next(bag.glob("*.mcap"))
    from mcap.reader import make_reader

    with open(mcap_file, "rb") as f:
        chunk = make_reader(f).get_summary().chunk_indexes[2]
    raw = bytearray(mcap_file.read_bytes())
    raw[chunk.chunk_start_offset + chunk.chunk_length - 8] ^= 0xFF  # in its compressed data
    mcap_file.write_bytes(bytes(raw))
    assert check.main([str(bag)]) == check.EXIT_UNREADABLE


def _notes(bag, capsys) -> list[str]:
    assert check.main([str(bag), "--json"]) == 0
    return json.loads(capsys.readouterr().out)["notes"]


def test_notes_say_only_what_the_bag_records(tmp_path, capsys):
    """The example bag was recorded before the fidelity parameter: its rung is the node's
    default, assumed, not a recorded value; without its /parameter_events it records no
    parameters at all; a bare .mcap file has no metadata.yaml to verify."""
    require_rclpy()
    from pathlib import Path

    from bag_support import copy_bags

    example = Path(__file__).resolve().parents[1] / "bags" / "example"
    notes = _notes(example, capsys)
    assert not any("recorded fidelity parameter" in n for n in notes)
    assert (
        "judged on the rigid rung: no fidelity was recorded (the parameters /drs recorded "
        "hold none); the node's default, rigid, was assumed"
    ) in notes
    assert "model parameters: recorded by /drs on /parameter_events" in notes
    bare = copy_bags([example], tmp_path / "bare", leave_out=["/parameter_events"])
    notes = _notes(bare, capsys)
    assert (
        "judged on the rigid rung: no fidelity was recorded (the bag records no parameters "
        "of the node); the node's default, rigid, was assumed"
    ) in notes
    assert any(n.startswith("model parameters: the seed's") for n in notes)
    assert notes[0].endswith("(CRCs, summary, metadata.yaml, exact CDR)")
    (mcap,) = bare.glob("*.mcap")
    assert _notes(mcap, capsys)[0].endswith("(CRCs, summary, exact CDR)")
