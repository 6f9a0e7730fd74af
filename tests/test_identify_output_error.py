"""Stage 2, output error, and the intervals: a hydraulic run's leak and jam recovered by
re-simulation; the profile likelihood against a brute-force profile; the fit's refusals."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from identify_support import hydraulic_signals, noisy_record, run_rung

from drs_model.errors import InputError, ParameterError
from drs_model.fidelity import HydraulicParams
from drs_model.identify import intervals as iv
from drs_model.identify.driver import fit
from drs_model.identify.output_error import OutputErrorProblem, fit_output_error, profile_chi2
from drs_model.identify.parameters import with_values

# the coverage benchmark's scenes (benchmarks/interval_coverage.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

MOVES = ((0, True), (60, False))


@pytest.fixture(scope="module")
def worn(params):
    """A hydraulic run with a leak to the outside (2e-13 m^3/(s Pa)) and a jam (30 N more
    Coulomb and breakaway friction), its stroke read with 10 um of noise."""
    truth = HydraulicParams(leak_to_outside=2e-13, coulomb_friction=70.0, breakaway_friction=90.0)
    table = run_rung("hydraulic", params, moves=MOVES, steps=120, hydraulic=truth)
    return truth, noisy_record(table, 1e-5, seed=3)


def _simulate(params):
    def simulate(values):
        p, hp = with_values(values, params, HydraulicParams())
        return hydraulic_signals(run_rung("hydraulic", p, moves=MOVES, steps=120, hydraulic=hp))

    return simulate


def test_output_error_recovers_a_leak_and_a_jam(worn, params):
    """From the equation error's start (from the defaults, 0 leak and 40 N, the output error
    alone ends in a local minimum: benchmarks/fit_speed.py's anchor)."""
    truth, record = worn
    names = ["leak_to_outside", "coulomb_friction", "breakaway_friction"]
    result = fit(record, names, "hydraulic", params, HydraulicParams(), simulate=_simulate(params))
    for e in result.estimates:
        assert e.stage == "output" and e.determined, e
        assert e.contains(float(getattr(truth, e.name))), e
    leak = result.estimate("leak_to_outside")
    assert leak.upper - leak.lower < 0.1 * truth.leak_to_outside
    stage = result.stages[-1]
    assert {s.name for s in stage.signals} == {"stroke", "piston_force", "pressure_a", "pressure_b"}
    assert stage.signals[0].residual_rms < 3e-5  # the stroke's noise, no model error left


def test_a_parameter_nothing_depends_on_is_reported_as_such(worn, params):
    """The relief valves never open in this run: their flow gain is in no simulated signal."""
    _, record = worn
    names = ["relief_flow_gain", "leak_to_outside", "coulomb_friction", "breakaway_friction"]
    result = fit(record, names, "hydraulic", params, HydraulicParams(), simulate=_simulate(params))
    relief = result.estimate("relief_flow_gain")
    assert not relief.determined and "zero sensitivity" in relief.reason
    assert result.estimate("leak_to_outside").determined


def _decay_problem(noise=0.02, seed=0):
    """``y = exp(-k t)`` with ``k = 3``, sampled at 20 instants with Gaussian noise."""
    t = np.linspace(0.0, 1.0, 20)
    y = np.exp(-3.0 * t) + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return OutputErrorProblem(
        ("k",),
        np.array([1.0]),
        np.array([0.0]),
        np.array([50.0]),
        np.array([1.0]),
        lambda v: {"y": np.exp(-v["k"] * t)},
        {"y": y},
        {"y": noise},
    )


def test_the_profile_interval_is_where_the_brute_force_profile_crosses():
    problem = _decay_problem()
    result = fit_output_error(problem)
    q = iv.quantile(0.95, result.dof)
    threshold = q * q * result.s2
    lo, hi = iv.profile_interval(
        profile_chi2(problem, result, 0),
        float(result.estimate[0]),
        q * math.sqrt(result.covariance[0, 0]),
        threshold,
        (0.0, 50.0),
        result.chi2,
    )
    grid = np.linspace(2.0, 4.0, 4001)
    inside = grid[[result.chi2_of(np.array([k])) - result.chi2 <= threshold for k in grid]]
    assert lo == pytest.approx(inside[0], abs=2e-3) and hi == pytest.approx(inside[-1], abs=2e-3)


@pytest.mark.parametrize("scale", [1.0, 1e-13, 1e9])
def test_the_profile_interval_does_not_depend_on_the_parameters_unit(scale):
    """The same problem with its parameter in another unit (a leak is ~1e-13 m^3/(s Pa)): the
    profile interval scales with it (an absolute floor on the search step collapsed a 1e-13
    interval onto its estimate)."""
    t = np.linspace(0.0, 1.0, 30)
    y = 2.0 * t + np.random.default_rng(1).normal(0.0, 0.1, t.size)
    problem = OutputErrorProblem(
        ("a",),
        np.array([scale]),
        np.array([-10.0 * scale]),
        np.array([10.0 * scale]),
        np.array([scale]),
        lambda v: {"y": v["a"] / scale * t},
        {"y": y},
        {"y": 0.1},
    )
    result = fit_output_error(problem)
    q = iv.quantile(0.95, result.dof)
    half = q * math.sqrt(result.covariance[0, 0])
    lo, hi = iv.profile_interval(
        profile_chi2(problem, result, 0),
        float(result.estimate[0]),
        half,
        q * q * result.s2,
        (-10.0 * scale, 10.0 * scale),
        result.chi2,
    )
    wald = iv.wald_interval(float(result.estimate[0]), half / q, q)
    assert lo == pytest.approx(wald[0], rel=1e-3) and hi == pytest.approx(wald[1], rel=1e-3)
    assert hi - lo == pytest.approx((wald[1] - wald[0]), rel=1e-2) and hi - lo > 0.1 * scale


def test_a_linear_model_agrees_with_its_linearisation():
    t = np.linspace(0.0, 1.0, 30)
    y = 2.0 * t + np.random.default_rng(1).normal(0.0, 0.1, t.size)
    problem = OutputErrorProblem(
        ("a",),
        np.array([1.0]),
        np.array([-10.0]),
        np.array([10.0]),
        np.array([1.0]),
        lambda v: {"y": v["a"] * t},
        {"y": y},
        {"y": 0.1},
    )
    result = fit_output_error(problem)
    ratios = iv.linearity_ratios(
        result.chi2_of,
        result.estimate,
        result.covariance,
        0,
        iv.quantile(0.95, result.dof),
        result.s2,
        result.chi2,
    )
    assert iv.agrees(ratios) and ratios == pytest.approx((1.0, 1.0), rel=1e-3)


@pytest.mark.parametrize(
    ("names", "rung", "error", "match"),
    [
        (["m_pist"], "kinematic", InputError, "models no forces"),
        (["leak_to_outside"], "rigid", ParameterError, "has no hydraulics.*leak_to_outside"),
        (["m_pistt"], "rigid", ParameterError, "'m_pistt' cannot be fitted.*m_pist"),
        (["Iz_pist"], "rigid", ParameterError, "the piston does not turn"),
        (["m_pist", "m_pist"], "rigid", InputError, r"named twice: \['m_pist'\]"),
        ([], "rigid", InputError, "at least one parameter"),
    ],
)
def test_a_fit_that_cannot_be_asked_is_refused(worn, params, names, rung, error, match):
    _, record = worn
    with pytest.raises(error, match=match):
        fit(record, names, rung, params)


def test_without_a_re_simulation_output_error_parameters_are_withheld(worn, params):
    _, record = worn
    result = fit(record, ["supply_pressure", "leak_to_outside"], "hydraulic", params)
    supply = result.estimate("supply_pressure")
    assert not supply.determined and "cannot be re-simulated" in supply.reason
    assert result.estimate("leak_to_outside").stage == "equation"


def test_each_signals_noise_is_the_records_own(params):
    """A force-commanded rigid run, its stroke read with 10 um of noise, fitted on its stroke:
    the noise the fit used is the record's (within 10 % of 10 um, not a sensor's assumed
    resolution), and the stage says it came from the record; on the same run read exactly the
    noise is the record's resolution, far below 10 um, the stage says it is noise-free, and the
    interval still holds the truth."""
    from identify_support import force_run

    table = force_run(params)

    def simulate(values):
        p, _ = with_values(values, params, HydraulicParams())
        return {"stroke": force_run(p)[:, 1]}

    widths = []
    for noise in (1e-5, 0.0):
        result = fit(
            noisy_record(table, noise, 1, stops_hold=True),
            ["m_wing"],
            "rigid",
            params,
            simulate=simulate,
            stage="output",
            signals=["stroke"],
        )
        (e,) = result.estimates
        assert e.contains(params.m_wing) and e.upper > e.lower, e
        note = result.stages[-1].notes[0]
        used = float(note.split("noise: stroke ")[1].split(" m")[0])
        if noise:
            assert used == pytest.approx(noise, rel=0.1)
            assert "m (from the record)" in note
        else:
            assert 0.0 < used < 0.1 * 1e-5
            assert "m (noise-free)" in note
        widths.append(e.upper - e.lower)
    assert widths[1] < 0.2 * widths[0]


def test_a_records_resolution_is_its_floats_spacing():
    from drs_model.identify.output_error import recorded_resolution, signal_noise

    x = np.linspace(0.01, 0.04, 1000)
    assert recorded_resolution(x) == pytest.approx(
        np.sqrt(np.mean(np.spacing(x) ** 2) / 12.0), rel=1e-12
    )
    assert signal_noise(x, x.copy(), 1) == recorded_resolution(x) > 0.0
    rng = np.random.default_rng(0)
    assert signal_noise(x + rng.normal(0.0, 1e-5, x.size), x, 1) == pytest.approx(1e-5, rel=0.1)


def test_a_signal_the_re_simulation_reproduces_to_its_bits_is_noise_free():
    """A record equal to the re-simulation at all but one sample (the fit's misfit there) has
    its resolution as noise, not that sample's residual spread over the others; a sensor that
    rounds to 1 um (a quantised LVDT) never lands on the simulation's bits: its noise is its
    rounding's, 1 um over sqrt 12, within 10 %."""
    from drs_model.identify.output_error import holds_exactly, recorded_resolution, signal_noise

    simulated = np.linspace(0.01, 0.04, 240)
    measured = simulated.copy()
    measured[0] += 1e-4
    assert holds_exactly(simulated, measured)
    assert signal_noise(simulated, measured, 1) == recorded_resolution(measured)
    quantised = np.round(simulated / 1e-6) * 1e-6
    assert not holds_exactly(simulated, quantised)
    assert signal_noise(simulated, quantised, 1) == pytest.approx(1e-6 / math.sqrt(12), rel=0.1)


def test_the_stopping_error_is_the_step_left_to_the_minimum():
    """A linear least-squares problem: at its solution the step left is 0 and the error the
    arithmetic's floor; 1e-6 away from it along each parameter, the step left is that offset."""
    from drs_model.identify.output_error import ARITHMETIC_ERROR, stopping_error

    rng = np.random.default_rng(2)
    A, b = rng.normal(size=(50, 3)), rng.normal(size=50)
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    at = stopping_error(A, A @ x - b, x)
    floor = ARITHMETIC_ERROR * np.maximum(np.abs(x), 1.0)
    assert np.allclose(at, floor, rtol=1e-3)
    offset = np.array([1e-6, -2e-6, 3e-6])
    away = stopping_error(A, A @ (x + offset) - b, x + offset)
    assert np.allclose(away, np.abs(offset), rtol=1e-6)


@pytest.mark.parametrize("scene", ["force", "stroke"])
def test_an_exactly_recorded_force_gives_intervals_as_narrow_as_its_arithmetic(scene, params):
    """The piston force a node bag records is the model's own arithmetic. Under force commands
    only its sample at rest depends on the wing's mass (the statics); under stroke commands
    every moving sample does. With 10 um of stroke noise, over 6 seeds: the force's noise is
    its resolution (under 1e-9 N: the re-simulation's agreement, taken at the estimate, not at
    a Jacobian's trial step), each interval holds the truth and is narrower than 1e-8 kg (was
    ~1e-5 kg: the force's noise had been its misfit's RMS), and the estimates' scatter is no
    wider than their stated error."""
    import interval_coverage as coverage  # noqa: PLC0415 - on the path set above

    table = coverage.scene_table(scene, params)
    values, stds = [], []
    for seed in range(6):
        record = coverage.record_of(table, scene, "node+noise", seed)
        result = fit(
            record,
            ["m_wing"],
            "rigid",
            params,
            simulate=coverage.simulator(scene, params),
            stage="output",
        )
        (e,) = result.estimates
        note = result.stages[-1].notes[0]
        force_noise = float(note.split("piston_force ")[1].split(" N")[0])
        assert force_noise < 1e-9 and "N (noise-free)" in note, note
        assert "m (from the record)" in note, note
        assert e.contains(params.m_wing) and 0.0 < e.upper - e.lower < 1e-8, e
        values.append(e.value)
        stds.append(e.std)
    assert np.std(values, ddof=1) <= np.mean(stds)


def test_an_output_error_on_signals_that_hold_no_parameter_withholds_them(params):
    """Stroke commands on the rigid rung: the flap follows the commanded path whatever its
    mass, so a fit on the stroke alone has nothing to fit. The output stage gives no value
    and says why (it raised 'needs at least one parameter' before); with both stages, the
    equation error's value and interval stand, and still hold the truth."""
    import interval_coverage as coverage  # noqa: PLC0415 - on the path set above

    table = coverage.scene_table("stroke", params)
    record = coverage.record_of(table, "stroke", "node+noise", 0)
    simulate = coverage.simulator("stroke", params)
    alone = fit(
        record, ["m_wing"], "rigid", params, simulate=simulate, stage="output", signals=["stroke"]
    )
    (e,) = alone.estimates
    assert not e.determined and "zero sensitivity" in e.reason, e
    assert alone.stages[-1].notes[0].startswith("no fit: the signals ['stroke']")
    both = fit(
        record, ["m_wing"], "rigid", params, simulate=simulate, stage="both", signals=["stroke"]
    )
    (e,) = both.estimates
    assert e.stage == "equation" and e.contains(params.m_wing), e
    assert not both.stages[-1].estimates[0].determined


def test_serially_correlated_residuals_widen_the_intervals():
    """The Newey-West inflation of the output error's covariance: independent residuals leave
    it at ~1; a residual that runs smoothly through the samples (a misfit, a re-run's rounding
    that drifts, here a 50-sample moving sum of noise) holds less information than its count,
    and widens the intervals (by less than the moving sum's 50x in variance: Newey-West sums 6
    lags at 600 samples, ceil(4 (n / 100)^(2/9)))."""
    from drs_model.identify.output_error import serial_inflation

    rng = np.random.default_rng(4)
    n = 600
    J = np.column_stack([np.ones(n), np.linspace(-1.0, 1.0, n)])
    information = np.linalg.pinv(J.T @ J)
    white = rng.normal(size=n)
    assert 1.0 <= serial_inflation(J, white, [n], information, 1.0) < 1.3
    smooth = np.convolve(rng.normal(size=n + 49), np.ones(50) / np.sqrt(50), mode="valid")
    assert serial_inflation(J, smooth, [n], information, 1.0) > 2.0
    # two signals, each a series of its own: the same white residuals split in two blocks
    assert 1.0 <= serial_inflation(J, white, [n // 2, n // 2], information, 1.0) < 1.3
