"""The peak force along a commanded path (drs_model.inverse.path_peak), compiled, against
independent statements: Newton-Euler (the seed's nine equations, not the fused closed form the
scan uses) on the scan's own grid and on a dense one, over hypothesis-drawn paths of several
segments; the compiled scan against its plain Python source; typed errors for paths the
mechanism cannot follow and for non-finite input."""

from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model import DRSParams
from drs_model import kinematics as kin
from drs_model.errors import AssemblyError, InputError
from drs_model.inverse import (
    PATH_FORCE_SAMPLES,
    FusedInverseDynamics,
    inverse_dynamics,
    path_peak,
    path_peak_force,
)
from drs_model.inverse.path_peak import REFINE_SAMPLES, scan_path
from drs_model.profile import quintic_move

#: The compiled scan needs numba (CI installs it: there a missing numba fails).
NEEDS_NUMBA = pytest.mark.skipif(
    importlib.util.find_spec("numba") is None and not os.environ.get("CI"),
    reason="numba is not installed (pip install drs[fast])",
)
P = DRSParams()
S_MIN, S_MAX = kin.stroke_limits(P)


def _newton_euler(seg, tau) -> np.ndarray:
    """Force [N] by Newton-Euler on segment ``seg`` at local times ``tau`` [s]."""
    state = kin.kinematic_state(*seg.evaluate(seg.t0 + np.asarray(tau, dtype=float)), P)
    return inverse_dynamics(state, P, "newton-euler").piston_force


#: A path: its moves' target fractions of the working stroke and durations [s] (0.004 s: fast
#: enough for inertia to matter; the start of each is where the last ended, at rest).
paths = st.lists(st.tuples(st.floats(0.0, 1.0), st.floats(0.004, 0.08)), min_size=1, max_size=4)


def _segments(moves):
    s, segs = S_MIN, []
    for fraction, duration in moves:
        target = S_MIN + fraction * (S_MAX - S_MIN)
        segs.append(quintic_move(P, target, duration, s))
        s = target
    return segs


@settings(max_examples=30, deadline=None)
@given(moves=paths)
def test_the_peak_is_newton_eulers_largest_force_along_the_path(moves):
    """Not below Newton-Euler's largest |F| on the scan's 33 samples a segment (1e-9: the two
    formulations' agreement), not above its largest on 4001 samples a segment by more than that
    grid's own shortfall (a sampled peak lies below the true one by ~(spacing)^2: 0.7 % at 33
    samples, so ~5e-7 at 4001 on a typical peak; 1e-5 for a sharp one), and Newton-Euler's
    force at the reported instant."""
    segs = _segments(moves)
    peak = path_peak_force(P, [g.coeffs for g in segs], [g.duration for g in segs])
    coarse = max(
        np.max(np.abs(_newton_euler(g, np.linspace(0, g.duration, PATH_FORCE_SAMPLES))))
        for g in segs
    )
    dense = max(np.max(np.abs(_newton_euler(g, np.linspace(0, g.duration, 4001)))) for g in segs)
    assert abs(peak.force) >= coarse * (1 - 1e-9)
    assert abs(peak.force) <= dense * (1 + 1e-5)
    seg = segs[peak.segment]
    assert 0.0 <= peak.time <= seg.duration
    assert peak.force == pytest.approx(float(_newton_euler(seg, [peak.time])[0]), rel=1e-9)
    assert peak.stroke == pytest.approx(float(seg.evaluate(seg.t0 + peak.time)[0]), abs=1e-12)


@NEEDS_NUMBA
@settings(max_examples=20, deadline=None)
@given(moves=paths)
def test_the_compiled_scan_is_its_plain_source(moves):
    """numba's build of scan_path against the same function run by Python (1e-12: the math
    library's last bits)."""
    assert path_peak._scan() is not scan_path  # compiled: else this compares Python with itself
    segs = _segments(moves)
    c = np.array([g.coeffs for g in segs], dtype=float)
    d = np.array([g.duration for g in segs], dtype=float)
    u, w = np.linspace(0, 1, PATH_FORCE_SAMPLES), np.linspace(0, 1, REFINE_SAMPLES)
    plain = scan_path(c, d, u, w, FusedInverseDynamics.from_params(P).consts)
    peak = path_peak_force(P, c, d)
    assert not plain[4]
    assert peak.segment == plain[1]
    assert peak.force == pytest.approx(plain[0], rel=1e-12)
    assert peak.time == pytest.approx(plain[2], rel=1e-12)


def test_a_path_beyond_where_the_loop_closes_raises_the_assembly_error():
    """A second segment resting 5 mm below the closed stroke, past the singular stroke near it:
    the loop cannot close there, and the error names that stroke."""
    s_bad = S_MIN - 0.005
    with pytest.raises(AssemblyError, match=f"cannot close at stroke {s_bad!r} m"):
        path_peak_force(P, [[S_MIN, 0, 0, 0, 0, 0], [s_bad, 0, 0, 0, 0, 0]], [0.01, 0.01])


@pytest.mark.parametrize(
    "coeffs, durations, match",
    [
        ([[0.02, np.nan, 0, 0, 0, 0]], [0.01], "coefficient must be finite, got nan"),
        ([[0.02, 0, 0, 0, 0, 0]], [np.inf], "duration must be finite, got inf"),
        ([[0.02, 0, 0, 0, 0, 0]], [0.01, 0.02], "one duration per segment"),
        ([[0.02, 1e300, 0, 0, 0, 0]], [1e10], r"not finite at 0\.0 s into segment 0.*overflow"),
    ],
)
def test_bad_paths_are_refused_by_name(coeffs, durations, match):
    with pytest.raises(InputError, match=match):
        path_peak_force(P, coeffs, durations)
