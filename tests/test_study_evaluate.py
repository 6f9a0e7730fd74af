"""drs_model.study.evaluate and .crossing: each batched result against an independent per-sample
derivation (the plain path: another formulation, scipy's own solvers), the nominal sample against
``drs peak`` itself, and a sample that does not assemble."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from drs_model.cli import main as drs_main
from drs_model.errors import AssemblyError, ParameterError
from drs_model.forward.formulations import StrokeMinimal
from drs_model.inverse import manoeuvre_force, peak_force, refine_extremum
from drs_model.kinematics import dead_centre, gap, solve_position, stroke_limits
from drs_model.params import DRSParams
from drs_model.study import RESULT_COLUMNS, Scene, evaluate

DESIGN = DRSParams()
FIELDS = ("L2", "y_D", "m_wing", "F_down_closed", "T_opening")
#: A handful of samples around the design (the first is the design itself).
SAMPLES = np.array(
    [
        [0.050, 0.154, 2.0, 819.11694, 0.010],
        [0.0501, 0.1541, 2.1, 760.0, 0.010],
        [0.0499, 0.1538, 1.9, 880.0, 0.011],
        [0.05005, 0.15395, 2.05, 819.0, 0.009],
        [0.04995, 0.15405, 1.95, 790.0, 0.0105],
    ]
)


def _drs_peak_json(*args: str) -> dict:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert drs_main(["peak", "--json", *args]) == 0
    return json.loads(out.getvalue())


@pytest.fixture(scope="module")
def batch():
    return evaluate(DESIGN, Scene(), FIELDS, SAMPLES)


def test_the_nominal_sample_reproduces_drs_peak(batch):
    """``drs peak`` (its own path: grid, scipy's bounded Brent, the force by inverse_dynamics),
    run as the command runs, against the study's row at the design: the same extrema. Both
    refine to 1e-12 s on a maximum, where the force is flat to ~1e-16 relative: equal to 1e-12
    relative, and the same printed digits."""
    ref = _drs_peak_json()
    assert batch["error"][0] is None
    assert batch["peak_force"][0] == pytest.approx(ref["peak_force"], rel=1e-12)
    assert batch["lowest_force"][0] == pytest.approx(ref["force_min"], rel=1e-12)
    assert batch["peak_time"][0] == pytest.approx(ref["peak_time"], abs=1e-9)
    assert batch["lowest_time"][0] == pytest.approx(ref["force_min_time"], abs=1e-9)
    for ours, theirs in (
        (batch["peak_force"][0], ref["peak_force"]),
        (batch["lowest_force"][0], ref["force_min"]),
    ):
        assert f"{ours:.9g}" == f"{theirs:.9g}"  # what `drs peak` prints
    # the design's gap rule holds at its own stops
    assert abs(batch["gap_error_closed"][0]) < 1e-15
    assert abs(batch["gap_error_open"][0]) < 1e-15


def test_a_study_sample_with_another_design_reproduces_drs_peak_of_it():
    """The design is the spec's, not the seed's: a lighter-flap design's nominal row is what
    ``drs peak --set Iz_wing=0.0024`` prints."""
    design = DRSParams(Iz_wing=0.0024)
    got = evaluate(design, Scene(), ("m_wing",), [[2.0]])
    ref = _drs_peak_json("--set", "Iz_wing=0.0024")
    assert got["peak_force"][0] == pytest.approx(ref["peak_force"], rel=1e-12)
    assert got["lowest_force"][0] == pytest.approx(ref["force_min"], rel=1e-12)


def _reference_time(p, s_from, s_to, force, horizon):
    """Opening or closing time by scipy's event location on formulation (b), ``s`` independent
    (the study integrates formulation (a), psi3 independent, with its own crossing search)."""
    rhs = StrokeMinimal(p).fun(lambda t: force)

    def reached(t, y):
        return y[0] - s_to

    reached.terminal = True
    sol = solve_ivp(
        rhs,
        (0.0, horizon),
        [s_from, 0.0],
        method="DOP853",
        rtol=1e-12,
        atol=[1e-15, 1e-13],
        events=reached,
    )
    assert sol.status == 1, sol.message
    return float(sol.t_events[0][0])


@pytest.mark.parametrize("i", range(len(SAMPLES)))
def test_the_batch_equals_a_per_sample_reference(batch, i):
    """Each row of the batch against the plain path, one sample at a time: the peak and lowest
    force by the Newton-Euler formulation (all reactions; the batch runs the fused closed form)
    with scipy's Brent, the dead centre and the gaps from :mod:`drs_model.kinematics`, the times
    from scipy's event location on another formulation."""
    p = DESIGN.replace(**dict(zip(FIELDS, SAMPLES[i], strict=True)))
    s_lo, s_hi = stroke_limits(DESIGN)
    limits = (s_lo, s_hi)
    pk = peak_force(p, "newton-euler", n=5001, s_limits=limits)
    t = np.linspace(0.0, p.T_total, 5001)
    low = refine_extremum(lambda tt: manoeuvre_force(tt, p, "newton-euler", limits), t, "min")
    # the formulations agree to ~1e-12 relative (tests/test_inverse.py)
    assert batch["peak_force"][i] == pytest.approx(pk.force, rel=1e-9)
    assert batch["peak_time"][i] == pytest.approx(pk.time, abs=1e-8)
    assert batch["lowest_force"][i] == pytest.approx(low.value, rel=1e-9)
    assert batch["lowest_time"][i] == pytest.approx(low.x, abs=1e-8)
    assert batch["dead_centre_margin"][i] == pytest.approx(s_lo - dead_centre(p), abs=1e-15)
    q = solve_position(np.array([s_lo, s_hi]), p)
    gaps = gap(q, p)
    assert batch["gap_error_closed"][i] == pytest.approx(gaps[0] - DESIGN.gap_closed, abs=1e-15)
    assert batch["gap_error_open"][i] == pytest.approx(gaps[1] - DESIGN.gap_open, abs=1e-15)
    scene = Scene()
    t_open = _reference_time(p, s_lo, s_hi, scene.opening_force, scene.horizon)
    t_close = _reference_time(p, s_hi, s_lo, scene.closing_force, scene.horizon)
    # rtol 1e-10 against event location at 1e-12 (measured: ~5e-14 s apart at the design)
    assert batch["opening_time"][i] == pytest.approx(t_open, abs=1e-10)
    assert batch["closing_time"][i] == pytest.approx(t_close, abs=1e-10)
    assert (batch["opening_status"][i], batch["closing_status"][i]) == ("ok", "ok")


def test_every_sample_differs_from_the_design_where_it_should(batch):
    """A lighter or heavier flap moves the peak; each sample of the batch gives its own numbers
    (a batch that broadcast one sample's constants to all would fail here)."""
    assert np.unique(batch["peak_force"]).size == len(SAMPLES)
    assert np.unique(batch["opening_time"]).size == len(SAMPLES)


def test_a_sample_that_does_not_assemble_is_a_row_with_its_reason():
    values = np.array([[0.050], [0.010], [0.0501]])
    got = evaluate(DESIGN, Scene(), ("L2",), values)
    with pytest.raises(ParameterError) as exc:
        DRSParams(L2=0.010)
    assert got["error"][1] == f"ParameterError: {exc.value}"
    assert "unreachable geometry" in got["error"][1]
    for name in RESULT_COLUMNS:
        assert np.isnan(got[name][1])
        assert np.isfinite(got[name][[0, 2]]).all()  # its neighbours still have results
    assert got["error"][0] is None and got["error"][2] is None


def test_a_sample_that_assembles_but_not_at_the_design_stroke_says_so():
    """L3 = 0.09 m assembles between its own gap-rule strokes, but not at the design's closed
    stroke, where the piston's stop is: a reason, no numbers."""
    p = DRSParams(L3=0.09)  # valid alone
    s_lo, _ = stroke_limits(DESIGN)
    with pytest.raises(AssemblyError):  # the plain path refuses the design's closed stroke
        solve_position(s_lo, p)
    got = evaluate(DESIGN, Scene(), ("L3",), [[0.09]])
    assert got["error"][0] == (
        f"AssemblyError: the loop cannot close at the design's closed stroke {s_lo!r} m"
    )
    assert all(np.isnan(got[name][0]) for name in RESULT_COLUMNS)


def test_a_force_below_the_holding_force_does_not_open():
    """The static force that holds the closed flap is ~1003 N: 500 N pushes the flap onto its
    closed stop, and a 0 N opening never happens; 3000 N opens it."""
    got = evaluate(DESIGN, Scene(opening_force=500.0), ("m_wing",), [[2.0]])
    assert got["opening_status"][0] == "moves away from the stop"
    assert np.isnan(got["opening_time"][0])
    assert got["closing_status"][0] == "ok"
    short = evaluate(DESIGN, Scene(horizon=0.005), ("m_wing",), [[2.0]])
    assert short["opening_status"][0] == "not within the horizon"  # it takes ~13 ms


_ROWS = np.column_stack(
    [
        0.05 + np.random.default_rng(1).normal(0.0, 2e-5, 24),
        2.0 + np.random.default_rng(2).uniform(-0.1, 0.1, 24),
    ]
)


@pytest.fixture(scope="module")
def whole_batch():
    return evaluate(DESIGN, Scene(grid=1001), ("L2", "m_wing"), _ROWS)


@settings(
    max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(st.integers(0, len(_ROWS) - 1), min_size=1, max_size=9))
def test_a_row_does_not_depend_on_its_batch(whole_batch, picks):
    """Any rows, in any order, repeated or not, give the bits they give in the whole batch: a
    study's numbers do not depend on its chunks or on how Dask groups them."""
    idx = np.array(picks)
    got = evaluate(DESIGN, Scene(grid=1001), ("L2", "m_wing"), _ROWS[idx])
    for name in RESULT_COLUMNS:
        assert np.array_equal(got[name], whole_batch[name][idx]), name
