"""The compiled paths (drs_model.compiled): numba's builds of the kernels against the plain ones
and against independent formulations, the RK driver against scipy's solvers and the exact
profile, typed failures.

Skipped when numba is missing, unless ``CI`` is set (CI installs every extra: a missing numba fails
there). No timing is asserted (benchmarks/work_precision.py measures it).

Measured accuracy on the manoeuvre (max |s - s_ref| over the 0.1 ms grid, numba 0.68.1):
dopri5 1.8e-7 / 5.1e-10 / 6.2e-12 m and dop853 4.7e-7 / 7.7e-10 / 7.7e-12 m at rtol 1e-6 / 1e-9
/ 1e-11, i.e. below 0.8 rtol [m]; the tests assert 2 rtol.
"""

from __future__ import annotations

import importlib.util
import math
import os
import subprocess
import sys

import forward_support
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model import forward as fw
from drs_model import kinematics as kin
from drs_model.constraints import constraint
from drs_model.errors import (
    InputError,
    IntegrationError,
    SingularConfigurationError,
    StrokeRangeError,
)
from drs_model.forward import COMPILED_METHODS, simulate

if importlib.util.find_spec("numba") is None:
    if os.environ.get("CI"):
        pytest.fail("numba is required under CI (pip install -e '.[fast]')", pytrace=False)
    pytest.skip("numba is not installed (pip install drs[fast])", allow_module_level=True)

from drs_model import elementwise  # noqa: E402
from drs_model.compiled import drivers, rk, rk_step  # noqa: E402
from drs_model.compiled import simulate as compiled  # noqa: E402
from drs_model.compiled.tableaux import tableau  # noqa: E402
from drs_model.compiled.warm import warm_up  # noqa: E402

METHODS = sorted(COMPILED_METHODS)  # dop853-numba, dopri5-numba
SCIPY_TWIN = {"dopri5-numba": "RK45", "dop853-numba": "DOP853"}
S0 = 0.02  # mid-stroke start [m]


@pytest.fixture(scope="module")
def mforce(params):
    return fw.ManoeuvreForce(params)


@pytest.fixture(scope="module")
def grid(params):
    return np.linspace(0.0, params.T_total, 501)


@pytest.fixture(scope="module", autouse=True)
def _compiled(params):
    warm_up(params)  # compile (or load from numba's cache) once for the module


def _start(params, s0=S0):
    return kin.solve_position(s0, params), np.zeros(3)


# ---- kernels ------------------------------------------------------------------------------------
def _same(a, b) -> bool:
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    return bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def test_compiled_kernels_equal_the_plain_ones_to_the_bit(params):
    """numba's builds of the one-sample kernels and fixed steps (what the real-time loop, the
    psi3 right-hand side and one inverse-dynamics force run, and the arctangent the force calls)
    give the plain Python functions' values to the last bit, NaN where they give NaN, inside and
    outside the assembly range."""
    from drs_model import kernels
    from drs_model.bodies import model_constants
    from drs_model.compiled.jit import compiled as build
    from drs_model.forward.fixed_step import PSI3_STEPS
    from drs_model.profile import drs_manoeuvre

    c = model_constants(params)
    k = drs_manoeuvre(params).constants()
    ca, ka = np.array(c), np.array(k)
    rng = np.random.default_rng(7)
    for b, bd, f, t, s, sd, sdd in rng.uniform(
        [0.2, -150.0, -5e3, -0.01, -0.004, -10.0, -1e4],
        [1.7, 150.0, 3e4, 0.06, 0.05, 10.0, 1e4],
        (3000, 7),
    ):
        for fn, args in (
            (kernels.psi3_acceleration, (b, bd, f)),
            (kernels.psi3_configuration, (b,)),
            (kernels.fused_force, (s, sd, sdd)),
            *((step, (b, bd, f, f, f, 1e-4)) for step in PSI3_STEPS.values()),
        ):
            assert _same(build(fn)(*args, ca), fn(*args, c)), (fn.__name__, args)
        assert _same(
            build(kernels.fused_manoeuvre_force)(t, ca, ka), kernels.fused_manoeuvre_force(t, c, k)
        )
    assert math.isnan(build(kernels.fused_force)(-0.01, 0.0, 0.0, ca))  # past the dead centre
    yx = rng.normal(size=(2000, 2)) * 10.0 ** rng.uniform(-5.0, 5.0, (2000, 2))
    for y, x in (*yx.tolist(), (-0.0, 1.0), (1.0, -1.0), (math.inf, 2.0), (math.nan, 1.0)):
        assert _same(build(kernels.arctangent)(y, x), kernels.arctangent(y, x)), (y, x)


def test_compiled_force_equals_newton_euler(params, mforce):
    """The compiled manoeuvre force (numba's build of kernels.fused_manoeuvre_force) equals an
    independent formulation, Newton-Euler on the numpy kinematics, to 1e-9 relative over 2,000
    times (rests, moves, joints); and the Python build of the same kernel to rounding."""
    from drs_model.inverse import manoeuvre_force

    t = np.concatenate(
        [np.linspace(-0.005, params.T_total + 0.005, 1995), np.array(mforce.breakpoints)]
    )
    got = elementwise.fused_manoeuvre_force(t, *compiled.manoeuvre_constants(mforce))
    ref = manoeuvre_force(t, params, "newton-euler")
    scale = np.max(np.abs(ref))
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * scale)
    python = np.array([mforce(float(x)) for x in t])
    np.testing.assert_allclose(got, python, rtol=1e-12, atol=1e-12 * scale)


def test_compiled_psi3_kernel_equals_the_numpy_reference(params):
    """The compiled psi3 acceleration against reference_rhs, which solves the projected equations
    with the numpy mass matrix, forces and velocity ratios (no kernel shared), at 200 random
    states around the stroke; no assembly gives NaN."""
    form = fw.Psi3Minimal(params)
    rng = np.random.default_rng(3)
    psi_c, psi_o = kin.flap_angle_limits(params)
    n = 200
    b = rng.uniform(min(psi_c, psi_o) - 0.3, max(psi_c, psi_o) + 0.3, n)
    bd = rng.uniform(-150.0, 150.0, n)
    f = rng.uniform(-3000.0, 3000.0, n)
    got = elementwise.psi3_acceleration(b, bd, f, compiled.psi3_constants(form))
    ref = np.array(
        [
            forward_support.reference_rhs(form, 0.0, np.array([x, v]), F)[1]
            for x, v, F in zip(b, bd, f, strict=True)
        ]
    )
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * np.max(np.abs(ref)))
    # no assembly -> NaN, as the Python kernel
    kc = compiled.psi3_constants(form)
    assert math.isnan(
        elementwise.psi3_acceleration(np.array([math.pi]), np.zeros(1), np.zeros(1), kc)[0]
    )


def test_each_driver_build_is_keyed_on_the_code_it_inlines():
    """numba's cache checks the stamp of the file a function is defined in (drivers.py), and a
    driver build inlines rk.integrate, its step and the kernels: each build carries the digest of
    their source files (rk.py, rk_step.py, kernels.py, jit.py, read here) among its closure's
    values, which numba's cache key includes, so an edit of them compiles anew."""
    import hashlib
    from pathlib import Path

    from drs_model import kernels
    from drs_model.compiled import jit as jit_module

    digest = hashlib.sha256()
    for module in (rk, rk_step, kernels, jit_module):
        digest.update(Path(module.__file__).read_bytes())
    for build in drivers.DRIVERS.values():
        texts = [
            c.cell_contents for c in build.py_func.__closure__ if isinstance(c.cell_contents, str)
        ]
        assert texts == [digest.hexdigest()]


def test_tableaux_satisfy_the_order_conditions():
    for method, order in (("dopri5", 5), ("dop853", 8)):
        a, c, e, e3, dense, ns, n_ext, err_order, _ = tableau(method)
        np.testing.assert_allclose(a.sum(axis=1), c, atol=1e-14)  # row sums = nodes
        bw = a[ns, :ns]
        for k in range(order):  # quadrature order: sum b c^k = 1/(k+1)
            assert bw @ c[:ns] ** k == pytest.approx(1.0 / (k + 1), abs=1e-13)
        assert err_order == order - 1 and n_ext >= ns + 1


def test_q_qd_from_the_closed_form(params, mforce, grid):
    sol = simulate(
        "psi3",
        mforce,
        (0.0, params.T_total),
        params=params,
        method="dop853-numba",
        rtol=1e-9,
        t_eval=grid,
    )
    form = fw.Psi3Minimal(params)
    q, qd = form.to_q_qd(sol.y)
    np.testing.assert_allclose(sol.q, q, rtol=0.0, atol=1e-13)
    np.testing.assert_allclose(sol.qd, qd, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(constraint(sol.q, params))) < 1e-15
    # the residuals as the scipy path gives them for minimal coordinates, one per output time
    res, vres = form.residual(sol.y)
    assert sol.residual.shape == sol.velocity_residual.shape == sol.t.shape == grid.shape
    np.testing.assert_array_equal(sol.residual, res)
    np.testing.assert_array_equal(sol.velocity_residual, vres)


# ---- the driver ---------------------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
def test_same_steps_as_the_scipy_twin(params, mforce, grid, method):
    """The port takes scipy's steps: same accepted steps and evaluations as RK45 / DOP853 (DOP853
    spends 3 dense-output evaluations less on a step ending exactly on an output time)."""
    kw = dict(params=params, rtol=1e-8, t_eval=grid)
    ours = simulate("psi3", mforce, (0.0, params.T_total), method=method, **kw)
    ref = simulate("psi3", mforce, (0.0, params.T_total), method=SCIPY_TWIN[method], **kw)
    assert ours.nsteps == ref.nsteps
    assert 0 <= ref.nfev - ours.nfev <= 3 * 5
    assert ours.method == method and ours.formulation == "psi3"
    assert ours.segments == ref.segments
    np.testing.assert_array_equal(ours.t, grid)
    # scipy restarts each segment from its dense output at the joint, we from the step's end:
    # rounding differences, grown by the instability
    np.testing.assert_allclose(ours.s, ref.s, rtol=0.0, atol=1e-11)


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
@pytest.mark.parametrize("dense", [False, True])
def test_the_held_segment_evaluates_its_force_once_and_changes_no_bit(
    params, mforce, grid, method, dense
):
    """The hold (10-40 ms) runs on one force value (kernels.profile_held): the run is the same,
    bit for bit, as one that calls the manoeuvre kernel at every stage of the hold."""
    form = compiled.psi3_formulation(params)
    _, args, _ = compiled._plan(
        form,
        mforce,
        method,
        0.0,
        params.T_total,
        1e-7,
        None,
        None,
        math.inf,
        1e-12,
        (),
        None,
        False,
        1_000_000,
    )
    kinds = args[1]
    assert kinds.tolist() == [1, 0, 1]  # manoeuvre kernel, one value, manoeuvre kernel
    every_stage = (args[0], np.ones_like(kinds), *args[2:])
    y = compiled._rest_state(params)
    te = grid if dense else np.zeros(0)
    driver = drivers.DRIVERS[method]
    held = driver(y[0], y[1], te, dense, *args)
    kernel = driver(y[0], y[1], te, dense, *every_stage)
    assert held[0] == rk.OK
    assert held[:9] == kernel[:9]  # status, nfev, steps, rejections, ...
    np.testing.assert_array_equal(held[9], kernel[9])  # t, y, q, qd: every bit
    # and the scipy path's piece of the hold is the kernel's value too
    piece = mforce.segment(params.T_opening, params.T_opening + params.T_still)
    for t in np.linspace(params.T_opening, params.T_opening + params.T_still, 7):
        assert piece(t) == mforce(t)


@pytest.mark.parametrize("method", METHODS)
def test_agrees_with_scipy_dop853_at_tight_tolerance(params, mforce, grid, method):
    ref = simulate(
        "psi3",
        mforce,
        (0.0, params.T_total),
        params=params,
        method="DOP853",
        rtol=1e-12,
        t_eval=grid,
    )
    ours = simulate(
        "psi3", mforce, (0.0, params.T_total), params=params, method=method, rtol=1e-12, t_eval=grid
    )
    np.testing.assert_allclose(ours.s, ref.s, rtol=0.0, atol=2e-11)
    np.testing.assert_allclose(ours.psi3, ref.psi3, rtol=0.0, atol=2e-10)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-11])
def test_reproduces_the_profile(params, mforce, grid, method, rtol):
    """Under its inverse-dynamics force the manoeuvre comes back: max|s err| < 2 rtol [m]
    (measured <= 0.8 rtol, module docstring)."""
    sol = simulate(
        "psi3", mforce, (0.0, params.T_total), params=params, method=method, rtol=rtol, t_eval=grid
    )
    err = np.max(np.abs(sol.s - mforce.profile(grid)[0]))
    assert err < 2.0 * rtol
    assert sol.nfev > 0 and sol.nsteps > 0 and sol.nrejected >= 0


@pytest.mark.parametrize("method", METHODS)
def test_error_scales_with_tolerance(params, mforce, grid, method):
    errs, nfev = [], []
    for rtol in (1e-5, 1e-7, 1e-9, 1e-11):
        sol = simulate(
            "psi3",
            mforce,
            (0.0, params.T_total),
            params=params,
            method=method,
            rtol=rtol,
            t_eval=grid,
        )
        errs.append(np.max(np.abs(sol.s - mforce.profile(grid)[0])))
        nfev.append(sol.nfev)
    assert all(a > 10.0 * b for a, b in zip(errs[:-1], errs[1:], strict=True)), errs
    assert nfev == sorted(nfev)


@pytest.mark.parametrize("method", METHODS)
def test_constant_force_and_every_step_output(params, method):
    t_end = 0.01
    ref = simulate(
        "psi3",
        500.0,
        (0.0, t_end),
        params=params,
        method="DOP853",
        rtol=1e-13,
        initial=_start(params),
        t_eval=[0.0025, 0.005, t_end],
    )
    sol = compiled.simulate_compiled(
        params, 500.0, (0.0, t_end), method=method[:-6], rtol=1e-11, initial=_start(params)
    )
    assert sol.t[0] == 0.0 and sol.t[-1] == t_end and np.all(np.diff(sol.t) > 0)
    assert sol.t.size == sol.nsteps + 1 and sol.y.shape == (2, sol.t.size)
    assert sol.s[-1] == pytest.approx(ref.s[-1], abs=1e-11)
    dense = compiled.simulate_compiled(
        params,
        500.0,
        (0.0, t_end),
        method=method[:-6],
        rtol=1e-11,
        initial=_start(params),
        t_eval=[0.0025, 0.005, t_end],
    )
    np.testing.assert_allclose(dense.s, ref.s, rtol=0.0, atol=1e-11)


@pytest.mark.parametrize("method", METHODS)
def test_step_force_restarts_at_the_step(params, method):
    kw = dict(params=params, rtol=1e-12, method=method)
    step = fw.StepForce(300.0, 600.0, 0.004)
    whole = simulate(
        "psi3", step, (0.0, 0.008), initial=_start(params), t_eval=[0.004, 0.008], **kw
    )
    assert whole.segments == [(0.0, 0.004), (0.004, 0.008)]
    first = simulate("psi3", 300.0, (0.0, 0.004), initial=_start(params), t_eval=[0.004], **kw)
    second = simulate("psi3", 600.0, (0.004, 0.008), y0=first.y[:, -1], t_eval=[0.008], **kw)
    np.testing.assert_allclose(whole.y[:, -1], second.y[:, -1], rtol=1e-12, atol=1e-13)
    ref = simulate(
        "psi3",
        step,
        (0.0, 0.008),
        params=params,
        rtol=1e-13,
        method="DOP853",
        initial=_start(params),
        t_eval=[0.008],
    )
    assert whole.s[-1] == pytest.approx(ref.s[-1], abs=1e-11)


# ---- failures -----------------------------------------------------------------------------------
def test_huge_force_leaves_the_stroke_range(params):
    s_min, s_max = kin.stroke_limits(params)
    with pytest.raises(
        StrokeRangeError,
        match=r"stroke s = 0\.05\d* m at t = .* leaves the "
        r"stroke range \[0\.000198\d*, 0\.0460\d*\] m",
    ):
        simulate(
            "psi3",
            1e6,
            (0.0, 0.05),
            params=params,
            method="dop853-numba",
            stroke_range=(s_min, s_max),
        )
    # without a range the link ends nearly horizontal: the psi3 formulation's own refusal,
    # at the same place as the scipy path
    with pytest.raises(SingularConfigurationError, match=r"cos psi1 = 0\.04\d* < min_cos_psi1"):
        simulate("psi3", 1e6, (0.0, 0.05), params=params, method="dopri5-numba")
    with pytest.raises(SingularConfigurationError, match=r"cos psi1 = .* < min_cos_psi1"):
        simulate("psi3", 0.0, (0.0, 0.01), params=params, y0=[1.55, 0.0], method="dop853-numba")


def test_dead_centre_passes_or_stops(params, mforce):
    low = 0.8 * mforce(0.0)
    sol = simulate("psi3", low, (0.0, 0.03), params=params, method="dop853-numba", rtol=1e-9)
    assert sol.s.min() < kin.stroke_limits(params)[0] - 1e-3  # through to the other side
    with pytest.raises(
        SingularConfigurationError, match=r"crosses the dead centre: psi3 = .* >= 1\.195\d* rad"
    ):
        simulate(
            "psi3",
            low,
            (0.0, 0.03),
            params=params,
            method="dop853-numba",
            rtol=1e-9,
            stop_at_dead_centre=True,
        )


def test_nan_force_is_typed(params):
    with pytest.raises(InputError, match=r"constant piston force must be finite"):
        simulate("psi3", math.nan, (0.0, 0.01), params=params, method="dop853-numba")
    # a non-finite force met inside the compiled driver (bypassing ConstantForce's validation)
    bad = object.__new__(fw.ConstantForce)
    object.__setattr__(bad, "value", math.nan)
    with pytest.raises(IntegrationError, match=r"piston force is not finite at t = 0\.0 s: nan"):
        compiled.simulate_compiled(params, bad, (0.0, 0.01))


def test_step_size_collapse_and_step_budget(params, mforce):
    with pytest.raises(IntegrationError, match=r"step size collapsed to .* < min_step = 0\.005"):
        simulate(
            "psi3",
            mforce,
            (0.0, 0.01),
            params=params,
            rtol=1e-12,
            min_step=5e-3,
            method="dopri5-numba",
        )
    with pytest.raises(IntegrationError, match=r"more than max_steps = 5 steps"):
        simulate("psi3", mforce, (0.0, 0.05), params=params, method="dop853-numba", max_steps=5)


def test_bad_arguments(params, mforce):
    with pytest.raises(InputError, match=r"integrates formulation 'psi3' only, got 'index1'"):
        simulate("index1", mforce, (0.0, 0.01), params=params, method="dop853-numba")
    with pytest.raises(InputError, match=r"a constant force, a StepForce or a ManoeuvreForce"):
        simulate("psi3", lambda t: 100.0, (0.0, 0.01), params=params, method="dop853-numba")
    with pytest.raises(InputError, match=r"t_eval must be sorted"):
        simulate(
            "psi3", 0.0, (0.0, 0.01), params=params, method="dop853-numba", t_eval=[0.005, 0.001]
        )
    with pytest.raises(InputError, match=r"method must be one of .*dop853-numba"):
        simulate("psi3", 0.0, (0.0, 0.01), params=params, method="dop853_numba")
    with pytest.raises(InputError, match=r"method must be 'dopri5' or 'dop853'"):
        compiled.simulate_compiled(params, 0.0, (0.0, 0.01), method="rk4")


def test_custom_air_law_force_runs_compiled(params, grid):
    """A ManoeuvreForce with its own air-law flap limits carries its constants: the compiled run
    matches the scipy twin on the same force (the port once had to refuse it)."""
    custom = fw.ManoeuvreForce(params, flap_limits=(1.2, 0.4))
    kw = dict(params=params, rtol=1e-9, t_eval=grid)
    ours = simulate("psi3", custom, (0.0, params.T_total), method="dop853-numba", **kw)
    ref = simulate("psi3", custom, (0.0, params.T_total), method="DOP853", **kw)
    assert ours.nsteps == ref.nsteps
    np.testing.assert_allclose(ours.q, ref.q, atol=1e-9)


def test_missing_numba_is_an_import_error():
    """Without numba a compiled method raises NumbaUnavailableError (an ImportError saying how to
    install numba); the model and the scipy methods run on the plain kernels."""
    code = (
        "import sys; sys.modules['numba'] = None\n"
        "from drs_model import DRSParams, NumbaUnavailableError, simulate\n"
        "p = DRSParams()\n"
        "assert simulate('psi3', 500.0, (0.0, 0.001), params=p).t[-1] == 0.001\n"
        "try:\n"
        "    simulate('psi3', 500.0, (0.0, 0.001), params=p, method='dop853-numba')\n"
        "except NumbaUnavailableError as exc:\n"
        "    assert isinstance(exc, ImportError)\n"
        "    print(exc)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], check=True, timeout=120, capture_output=True, text=True
    )
    assert "pip install 'drs[fast]'" in out.stdout


def test_importing_the_model_does_not_import_numba():
    code = "import sys, drs_model.forward; assert 'numba' not in sys.modules, 'numba imported'"
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_inlined_fused_batch_path_is_the_plain_kernel():
    """The batch path of the fused inverse dynamics (its kernels inlined into the gufunc) gives,
    at times through the open-hold-close manoeuvre and past it, the plain Python kernel's force
    (rounding aside) and the build of the registered, not inlined, kernels to the bit."""
    from drs_model import DRSParams, elementwise, kernels
    from drs_model.compiled.jit import compiled
    from drs_model.inverse import FusedInverseDynamics

    fid = FusedInverseDynamics.from_params(DRSParams())
    c, k = np.asarray(fid.consts, float), np.asarray(fid.profile, float)
    t = np.linspace(-0.01, 0.32, 2001)
    batch = elementwise.fused_manoeuvre_force(t, c, k)

    def registered(t, c, k):  # the kernel as every other compiled caller builds it
        return kernels.fused_manoeuvre_force(t, c, k)

    plain = np.array([kernels.fused_manoeuvre_force(x, fid.consts, fid.profile) for x in t])
    np.testing.assert_allclose(batch, plain, rtol=1e-12, atol=1e-9)
    not_inlined = np.array([compiled(registered)(x, c, k) for x in t])
    np.testing.assert_array_equal(batch, not_inlined)


def test_the_gufuncs_read_strided_constants_as_contiguous_ones():
    """The gufuncs index their constants without strides (C-contiguous signatures):
    elementwise hands them contiguous copies, so constants given as a strided view (every
    second element of a longer array) give the same forces to the bit."""
    from drs_model import DRSParams, elementwise
    from drs_model.inverse import FusedInverseDynamics

    fid = FusedInverseDynamics.from_params(DRSParams())
    c, k = np.asarray(fid.consts, float), np.asarray(fid.profile, float)
    c_view, k_view = np.repeat(c, 2)[::2], np.repeat(k, 2)[::2]
    assert not c_view.flags.c_contiguous and not k_view.flags.c_contiguous
    t = np.linspace(0.0, 0.05, 201)
    np.testing.assert_array_equal(
        elementwise.fused_manoeuvre_force(t, c_view, k_view),
        elementwise.fused_manoeuvre_force(t, c, k),
    )
    np.testing.assert_array_equal(
        elementwise.fused_manoeuvre_force_series(t, c_view, k_view),
        elementwise.fused_manoeuvre_force_series(t, c, k),
    )


@settings(max_examples=40, deadline=None)
@given(
    times=st.lists(st.floats(-0.01, 0.06, allow_nan=False), min_size=0, max_size=60),
    order=st.sampled_from(["sorted", "drawn", "reversed"]),
    shape=st.sampled_from(["flat", "column"]),
)
def test_the_series_path_is_the_per_time_path_to_the_bit(times, order, shape):
    """elementwise.fused_manoeuvre_force_series (the force computed once per stretch of rest)
    gives every time's force exactly as the per-element gufunc does: in any order, with times
    repeated, resting or moving, in any shape (the seed manoeuvre: 10 ms open, 30 ms hold)."""
    from drs_model import DRSParams, elementwise
    from drs_model.inverse import FusedInverseDynamics

    fid = FusedInverseDynamics.from_params(DRSParams())
    # the move's ends and the hold's, where the branch changes, and draws in between
    t = np.array(times + [0.0, 0.01, 0.01, 0.04, 0.05, 0.05, 0.005, 0.045])
    t = {"sorted": np.sort(t), "drawn": t, "reversed": np.sort(t)[::-1]}[order]
    t = t.reshape(-1, 1) if shape == "column" else t
    series = elementwise.fused_manoeuvre_force_series(t, fid.consts, fid.profile)
    per_time = elementwise.fused_manoeuvre_force(t, fid.consts, fid.profile)
    assert series.shape == t.shape
    np.testing.assert_array_equal(series, per_time)
