"""The fidelity chart: scenes, the batch kinematic path, the ladder's errors and needs, and
``drs fidelity``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from drs_model import DRSParams, drs_manoeuvre
from drs_model import kinematics as kin
from drs_model.cli import main
from drs_model.fidelity.ladder import event_times, measure, needed_rung
from drs_model.fidelity.scenes import SCENES, Scene, run_scene

P = DRSParams()
#: The gap stream's lap shortened to 9 s (its commands scaled), as ``--lap 9`` does.
LAP = 9.0


@pytest.mark.parametrize("scene", ["open-hold-close", "open-hold-close-100ms", "gap-stream"])
def test_batch_kinematic_equals_the_stepped_one(scene):
    sc = SCENES[scene]
    if sc.repeat > 1:
        sc = Scene(sc.name, LAP, tuple((t / 10.0, a, x) for t, a, x in sc.events))
    stepped, batch = run_scene("kinematic", sc, P), run_scene("kinematic", sc, P, batch=True)
    np.testing.assert_array_equal(stepped.t, batch.t)
    np.testing.assert_allclose(batch.stroke, stepped.stroke, rtol=0, atol=1e-15)
    np.testing.assert_allclose(batch.gap, stepped.gap, rtol=0, atol=1e-15)
    assert np.ptp(stepped.gap) > 0.039  # the flap did open


def test_event_times_of_the_seed_manoeuvre_on_the_rigid_rung():
    """Independently: the instants the manoeuvre's gap crosses 95 % of its travel (opening) and
    5 % (closing), by a root finder on the profile; the chart's times are the first 1 ms
    samples past them."""
    man = drs_manoeuvre(P)

    def gap_at(t):
        return float(kin.gap(kin.solve_position(man.evaluate(np.array([t]))[0], P), P)[0])

    span = P.gap_open - P.gap_closed
    t_open = brentq(lambda t: gap_at(t) - (P.gap_closed + 0.95 * span), 1e-4, P.T_opening)
    t0_close = P.T_opening + P.T_still
    t_close = brentq(lambda t: gap_at(t) - (P.gap_closed + 0.05 * span), t0_close, man.t_end)
    sc = SCENES["open-hold-close"]
    opening, closing = event_times(run_scene("rigid", sc, P), sc, P)
    assert opening == pytest.approx(math.ceil(t_open / 1e-3) * 1e-3, abs=1e-12)
    assert closing == pytest.approx(math.ceil(t_close / 1e-3) * 1e-3 - t0_close, abs=1e-12)


@pytest.fixture(scope="module")
def rows():
    return measure(P, lap_seconds=LAP)


def test_ladder_errors_and_needs(rows):
    by = {(r.scene, r.label): r for r in rows}
    # the reference agrees with itself run by the default step, and the lower rungs with each
    # other on positions (they follow the same path)
    hyd = by[("open-hold-close-100ms", "hydraulic")]
    assert hyd.errors["stroke"] < 1e-5 and hyd.errors["force"] < 100.0
    kin_row, rigid = by[("gap-stream", "kinematic")], by[("gap-stream", "rigid")]
    assert kin_row.errors["gap"] == rigid.errors["gap"]
    assert math.isnan(kin_row.errors["force"]) and not math.isnan(rigid.errors["force"])
    # the seed's 10 ms opening is beyond the valve: the ideal rungs are ~33 mm off in the gap
    assert by[("open-hold-close", "rigid")].errors["gap"] > 0.02
    assert by[("force-step", "kinematic")].refused is not None
    # what each scene needs
    assert needed_rung(rows, "gap-stream", ("gap",), {"gap": 1e-3}) == "kinematic (batch)"
    assert needed_rung(rows, "open-hold-close", ("gap",)) == "hydraulic"
    assert needed_rung(rows, "gap-stream", ("gap", "force"), {"gap": 1e-3}) == "hydraulic"
    # and the batch path is the cheapest way to the gap
    assert by[("gap-stream", "kinematic (batch)")].cost_per_second < rigid.cost_per_second


def test_drs_fidelity_json_and_plot(capsys, tmp_path):
    png = tmp_path / "fidelity.png"
    assert main(["fidelity", "--lap", "3", "--plot", str(png), "--gap-tol", "1e-3", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["tolerances"]["gap"] == 1e-3 and d["plot"] == str(png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    scenes = {r["scene"] for r in d["rows"]}
    assert scenes == set(SCENES) and set(d["needs"]) == scenes
    # the gap of a stream needs the kinematic rung; whether its batch or its step-by-step run
    # is the cheaper is a measured cost (a loaded machine chose the step-by-step once)
    assert d["needs"]["gap-stream"]["gap"] in {"kinematic (batch)", "kinematic"}


def test_drs_fidelity_refuses_a_bad_tolerance(capsys):
    assert main(["fidelity", "--force-tol", "-1"]) == 2
    assert "--force-tol must be a finite number > 0, got -1.0" in capsys.readouterr().err
