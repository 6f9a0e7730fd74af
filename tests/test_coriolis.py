"""Rotating-frame kinematics of seed 000: collar on a rotating rod and the slotted link.

Reference values come from the seed text (its MATLAB expressions, re-typed below) or from hand
derivations written out in the tests, never from this package's output.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ros_support import require_module

from drs_model import AssemblyError, DRSError, InputError, ParameterError, plotting
from drs_model import coriolis as cor
from drs_model.cli import main

SQ3 = math.sqrt(3.0)

# ---- seed 000, example 2 MATLAB (degrees), re-typed from the seed text ------------------------


def cosd(x):
    return np.cos(np.radians(x))


def sind(x):
    return np.sin(np.radians(x))


def VB_x(theta, x):  # noqa: N802 - the seed's names
    return 0.5 * (cosd(theta) - x * sind(theta))


def VB_y(theta, x):  # noqa: N802
    return 0.5 * (sind(theta) + x * cosd(theta))


# The seed never defines aB_x, aB_y. Derived by hand here:
# a = (r'' - w^2 r) e_x + (al r + 2 w r') e_y with r' = 0.5, r'' = 0.1, w = 0.5, al = 0.05,
# so (0.1 - 0.25 x) and (0.05 x + 0.5).
def aB_x(theta, x):  # noqa: N802
    return (0.1 - 0.25 * x) * cosd(theta) - (0.05 * x + 0.5) * sind(theta)


def aB_y(theta, x):  # noqa: N802
    return (0.1 - 0.25 * x) * sind(theta) + (0.05 * x + 0.5) * cosd(theta)


# ---- seed 000, example 3 MATLAB (mm, degrees, clockwise-positive rod rates), re-typed ----------
S_OMEGA, S_ALPHA, S_D, S_R = 10.0, 2.0, 1000.0, 250.0


def seed_omega_AC(theta):  # noqa: N802
    omega, d, r = S_OMEGA, S_D, S_R
    return -(omega * r * (r - d * np.cos((np.pi * theta) / 180))) / (
        d**2 - 2 * np.cos((theta * np.pi) / 180) * d * r + r**2
    )


def seed_v_stroke(theta):
    omega, d, r = S_OMEGA, S_D, S_R
    return -(d * omega * r * np.sin((np.pi * theta) / 180)) / (
        d**2 + r**2 - 2 * d * r * np.cos((theta * np.pi) / 180)
    ) ** (1 / 2)


def seed_alpha_AC(theta):  # noqa: N802
    omega, alpha, d, r = S_OMEGA, S_ALPHA, S_D, S_R
    w, v = seed_omega_AC(theta), seed_v_stroke(theta)
    c, s = np.cos((np.pi * theta) / 180), np.sin((np.pi * theta) / 180)
    root = (d**2 - 2 * np.cos((theta * np.pi) / 180) * d * r + r**2) ** (1 / 2)
    return (
        2 * d**2 * w * v
        + 2 * w * r**2 * v
        - alpha * r**2 * root
        + alpha * d * r * c * root
        - 4 * d * w * r * v * c
        - d * omega**2 * r * s * root
    ) / (d**2 + r**2 - 2 * d * r * np.cos((theta * np.pi) / 180)) ** (3 / 2)


def seed_a_stroke(theta):
    omega, alpha, d, r = S_OMEGA, S_ALPHA, S_D, S_R
    w = seed_omega_AC(theta)
    c, s = np.cos((theta * np.pi) / 180), np.sin((theta * np.pi) / 180)
    return -(
        d**2 * w**2
        + c * d * omega**2 * r
        - 2 * c * d * w**2 * r
        + alpha * s * d * r
        - omega**2 * r**2
        + w**2 * r**2
    ) / (d**2 + r**2 - 2 * d * r * np.cos((theta * np.pi) / 180)) ** (1 / 2)


# ---- example 1 ----------------------------------------------------------------------------------
def test_example_1_defaults_are_the_seed_data():
    ex = cor.SEED_COLLAR
    assert (ex.omega, ex.alpha, ex.r, ex.r_dot, ex.r_ddot) == (0.5, 0.05, 0.25, 0.5, 0.1)
    assert math.degrees(ex.theta) == pytest.approx(120.0, abs=1e-12)
    assert (ex.r_max, math.degrees(ex.theta_max)) == (10.0, pytest.approx(180.0))


def test_example_1_every_term_against_hand_values():
    k = cor.SEED_COLLAR.kinematics()
    rot, fix = k.rotating, k.fixed
    # rotating axes, by hand: v = (r', w r), a = (r'' - w^2 r, al r + 2 w r')
    np.testing.assert_allclose(rot.position, [0.25, 0.0], atol=1e-15)
    np.testing.assert_allclose(rot.velocity.relative, [0.5, 0.0], atol=1e-15)
    np.testing.assert_allclose(rot.velocity.transport, [0.0, 0.125], atol=1e-15)
    np.testing.assert_allclose(rot.velocity.total, [0.5, 0.125], atol=1e-15)
    np.testing.assert_allclose(rot.acceleration.relative, [0.1, 0.0], atol=1e-15)
    np.testing.assert_allclose(rot.acceleration.centripetal, [-0.0625, 0.0], atol=1e-15)
    np.testing.assert_allclose(rot.acceleration.tangential, [0.0, 0.0125], atol=1e-15)
    np.testing.assert_allclose(rot.acceleration.coriolis, [0.0, 0.5], atol=1e-15)
    np.testing.assert_allclose(rot.acceleration.total, [0.0375, 0.5125], atol=1e-15)
    # fixed axes: cos 120 = -1/2, sin 120 = sqrt(3)/2
    c, s = -0.5, SQ3 / 2
    np.testing.assert_allclose(fix.position, [0.25 * c, 0.25 * s], atol=1e-15)
    np.testing.assert_allclose(
        fix.velocity.total, [0.5 * c - 0.125 * s, 0.5 * s + 0.125 * c], atol=1e-15
    )
    np.testing.assert_allclose(
        fix.acceleration.total, [0.0375 * c - 0.5125 * s, 0.0375 * s + 0.5125 * c], atol=1e-15
    )
    np.testing.assert_allclose(fix.acceleration.coriolis, [-0.5 * s, 0.5 * c], atol=1e-15)
    # the seed's plot-marker values VB_x(120, 0.25), VB_y(120, 0.25)
    assert fix.velocity.total[0] == pytest.approx(VB_x(120.0, 0.25), abs=1e-15)
    assert fix.velocity.total[1] == pytest.approx(VB_y(120.0, 0.25), abs=1e-15)


def test_example_2_maps_match_the_seed_matlab():
    grid = cor.SEED_COLLAR.grid(n_theta=361, n_r=21)  # the seed's meshgrid step: 0.5 m, 0.5 deg
    x, th = grid.motion.r, np.degrees(grid.motion.theta)
    assert x.shape == th.shape == (361, 21)
    np.testing.assert_allclose(x[0], np.arange(0.0, 10.01, 0.5), atol=1e-12)
    np.testing.assert_allclose(th[:, 0], np.arange(0.0, 180.01, 0.5), atol=1e-12)
    v, a = grid.fixed.velocity.total, grid.fixed.acceleration.total
    np.testing.assert_allclose(v[..., 0], VB_x(th, x), atol=1e-13)
    np.testing.assert_allclose(v[..., 1], VB_y(th, x), atol=1e-13)
    np.testing.assert_allclose(a[..., 0], aB_x(th, x), atol=1e-13)
    np.testing.assert_allclose(a[..., 1], aB_y(th, x), atol=1e-13)


# ---- finite differences along trajectories ------------------------------------------------------
def _trajectory(t):
    """theta(t), r(t) and their derivatives, differentiated by hand."""
    theta = 0.3 + 0.7 * t + 0.4 * np.sin(1.3 * t)
    omega = 0.7 + 0.52 * np.cos(1.3 * t)
    alpha = -0.676 * np.sin(1.3 * t)
    r = 0.5 + 0.2 * np.cos(2.0 * t) + 0.1 * t
    r_dot = -0.4 * np.sin(2.0 * t) + 0.1
    r_ddot = -0.8 * np.cos(2.0 * t)
    return theta, omega, alpha, r, r_dot, r_ddot


def test_collar_velocity_and_acceleration_against_finite_differences():
    # Central differences, O(h^2) (measured): h = 1e-4 leaves ~8e-9 m/s on the velocity and
    # h = 1e-3 leaves ~1.2e-6 m/s^2 on the acceleration (rounding ~1e-16/h^2 = 1e-10). Tolerances:
    # about 10x those.
    t = np.linspace(0.0, 6.0, 61)
    k = cor.collar_kinematics(*_trajectory(t))

    def pos(tt, frame="fixed"):
        kk = cor.collar_kinematics(*_trajectory(tt))
        return getattr(kk, frame).position

    h = 1e-4
    v_fd = (pos(t + h) - pos(t - h)) / (2 * h)
    np.testing.assert_allclose(k.fixed.velocity.total, v_fd, rtol=0, atol=1e-7)
    h = 1e-3
    a_fd = (pos(t + h) - 2 * pos(t) + pos(t - h)) / h**2
    np.testing.assert_allclose(k.fixed.acceleration.total, a_fd, rtol=0, atol=1e-5)
    # in the rotating frame, the derivatives of the rotating coordinates are the relative terms
    h = 1e-4
    vr_fd = (pos(t + h, "rotating") - pos(t - h, "rotating")) / (2 * h)
    np.testing.assert_allclose(k.rotating.velocity.relative, vr_fd, rtol=0, atol=1e-7)
    h = 1e-3
    ar_fd = (pos(t + h, "rotating") - 2 * pos(t, "rotating") + pos(t - h, "rotating")) / h**2
    np.testing.assert_allclose(k.rotating.acceleration.relative, ar_fd, rtol=0, atol=1e-5)


def test_slotted_link_rates_against_finite_differences_over_a_revolution():
    # theta(t) = theta0 + w0 t + al t^2 / 2, so omega(t) = w0 + al t, alpha = al.
    w0, al, r, d = 10.0, 2.0, 0.25, 1.0
    theta0 = np.linspace(0.0, 2 * np.pi, 145)

    def position(t):
        return cor.slotted_link_position(theta0 + w0 * t + 0.5 * al * t**2, r, d)

    m = cor.slotted_link_closed_form(theta0, w0, al, r, d)
    # The rod angle's derivatives grow like w0^n. Central differences (measured): h = 1e-5 leaves
    # ~1e-8 on omega_rod and L' (values up to 3.3 rad/s, 2.5 m/s); h = 2e-5 leaves ~2e-6 on
    # alpha_rod and L'' (values up to 33; truncation ~h^2 |phi''''|/12 balanced against rounding
    # ~eps |phi| / h^2). Tolerances: 10x those.
    h = 1e-5
    (phi_p, L_p), (phi_m, L_m) = position(h), position(-h)
    dphi = np.angle(np.exp(1j * (phi_p - phi_m)))  # phi wraps at +-pi where theta = 0
    np.testing.assert_allclose(m.omega_rod, dphi / (2 * h), rtol=0, atol=1e-7)
    np.testing.assert_allclose(m.stroke_velocity, (L_p - L_m) / (2 * h), rtol=0, atol=1e-7)
    h = 2e-5
    (phi_p, L_p), (phi_0, L_0), (phi_m, L_m) = position(h), position(0.0), position(-h)
    d2phi = np.angle(np.exp(1j * (phi_p - phi_0))) - np.angle(np.exp(1j * (phi_0 - phi_m)))
    np.testing.assert_allclose(m.alpha_rod, d2phi / h**2, rtol=0, atol=2e-5)
    np.testing.assert_allclose(
        m.stroke_acceleration, (L_p - 2 * L_0 + L_m) / h**2, rtol=0, atol=2e-5
    )


# ---- example 3: closure vs closed form vs the seed ---------------------------------------------
THETA_REV = np.linspace(0.0, 2 * np.pi, 3601)


def test_example_3_defaults_are_the_seed_data():
    link = cor.SEED_SLOTTED_LINK
    assert (link.r, link.d, link.omega, link.alpha) == (0.25, 1.0, 10.0, 2.0)


def test_slotted_link_position_closes_the_loop():
    # reference configuration check first: B = C + L (cos phi, sin phi) to 1e-12 over a revolution
    phi, L = cor.slotted_link_position(THETA_REV, 0.25, 1.0)
    b = 0.25 * np.stack((np.cos(THETA_REV), np.sin(THETA_REV)), axis=-1)
    c_plus = np.array([1.0, 0.0]) + L[:, None] * np.stack((np.cos(phi), np.sin(phi)), axis=-1)
    assert np.max(np.abs(b - c_plus)) < 1e-12
    np.testing.assert_allclose(L.min(), 0.75, rtol=1e-12)  # d - r at theta = 0
    np.testing.assert_allclose(L.max(), 1.25, rtol=1e-12)  # d + r at theta = 180 deg


@pytest.mark.parametrize("link", [cor.SEED_SLOTTED_LINK, cor.SlottedLinkExample(0.9, 1.0, -3, 7)])
def test_closure_equations_agree_with_closed_form_over_a_revolution(link):
    a = link.solve(THETA_REV, "closed-form")
    b = link.solve(THETA_REV, "closure")
    for field in a._fields:
        x, y = getattr(a, field), getattr(b, field)
        if field == "rod_angle":
            x, y = np.cos(x) + 1j * np.sin(x), np.cos(y) + 1j * np.sin(y)
        scale = max(1.0, float(np.max(np.abs(x))))
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-11 * scale, err_msg=field)


def test_closed_form_matches_the_seed_matlab_expressions():
    theta_deg = np.linspace(0.0, 360.0, 721)
    m = cor.slotted_link_closed_form(np.radians(theta_deg))  # defaults: the seed's data in SI
    # seed: clockwise-positive rod rates, mm; v_stroke > 0 when the pin-to-collar length shrinks
    np.testing.assert_allclose(-m.omega_rod, seed_omega_AC(theta_deg), rtol=0, atol=1e-12)
    np.testing.assert_allclose(-1e3 * m.stroke_velocity, seed_v_stroke(theta_deg), atol=1e-9)
    np.testing.assert_allclose(-m.alpha_rod, seed_alpha_AC(theta_deg), rtol=0, atol=1e-11)
    np.testing.assert_allclose(-1e3 * m.stroke_acceleration, seed_a_stroke(theta_deg), atol=1e-8)
    seed = cor.to_seed_convention(m)
    np.testing.assert_allclose(seed["omega_AC"], seed_omega_AC(theta_deg), atol=1e-12)
    np.testing.assert_allclose(seed["v_stroke"], seed_v_stroke(theta_deg), atol=1e-9)
    np.testing.assert_allclose(seed["alpha_AC"], seed_alpha_AC(theta_deg), atol=1e-11)
    np.testing.assert_allclose(seed["a_stroke"], seed_a_stroke(theta_deg), atol=1e-8)
    np.testing.assert_allclose(seed["theta_deg"], theta_deg, atol=1e-12)


def test_slotted_link_special_positions_by_hand():
    m = cor.slotted_link_closed_form(np.radians([0.0, 90.0, 180.0]))
    # theta = 0: pin at (r, 0) moving +Y at w r, seen from C at distance d - r along -X: the rod
    # turns clockwise at w r / (d - r); L'' = w^2 r d / (d - r) (pin's centripetal along the rod)
    assert m.omega_rod[0] == pytest.approx(-10 * 0.25 / 0.75, rel=1e-14)
    assert m.stroke_velocity[0] == pytest.approx(0.0, abs=1e-14)
    assert m.stroke_acceleration[0] == pytest.approx(100 * 0.25 * 1.0 / 0.75, rel=1e-14)
    # theta = 90 deg: L = sqrt(d^2 + r^2); L' = w r d / L (pin velocity -X projected on C->B)
    L90 = math.hypot(1.0, 0.25)
    assert m.stroke[1] == pytest.approx(L90, rel=1e-15)
    assert m.stroke_velocity[1] == pytest.approx(10 * 0.25 * 1.0 / L90, rel=1e-14)
    assert m.omega_rod[1] == pytest.approx(10 * 0.25 * 0.25 / L90**2, rel=1e-14)
    # theta = 180 deg: counter-clockwise w r / (d + r); L'' = -w^2 r d / (d + r)
    assert m.omega_rod[2] == pytest.approx(10 * 0.25 / 1.25, rel=1e-14)
    assert m.stroke_acceleration[2] == pytest.approx(-100 * 0.25 / 1.25, rel=1e-14)
    assert m.alpha_rod[2] == pytest.approx(2 * 0.25 / 1.25, rel=1e-14)


# ---- properties ---------------------------------------------------------------------------------
finite_rate = st.floats(-20.0, 20.0, allow_nan=False)
angle = st.floats(-10.0, 10.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(angle, finite_rate, finite_rate, st.floats(-5.0, 5.0), finite_rate, finite_rate)
def test_terms_sum_to_totals_and_frames_agree(theta, omega, alpha, r, r_dot, r_ddot):
    k = cor.collar_kinematics(theta, omega, alpha, r, r_dot, r_ddot)
    for frame in (k.fixed, k.rotating):
        v, a = frame.velocity, frame.acceleration
        np.testing.assert_allclose(v.relative + v.transport, v.total, atol=1e-12)
        np.testing.assert_allclose(
            a.relative + a.centripetal + a.tangential + a.coriolis, a.total, atol=1e-9
        )
    c, s = math.cos(theta), math.sin(theta)
    rot = np.array([[c, -s], [s, c]])
    pairs = [(k.fixed.position, k.rotating.position)]
    pairs += list(zip(k.fixed.velocity, k.rotating.velocity, strict=True))
    pairs += list(zip(k.fixed.acceleration, k.rotating.acceleration, strict=True))
    for fixed, rotating in pairs:
        np.testing.assert_allclose(fixed, rot @ rotating, atol=1e-9)
        np.testing.assert_allclose(rot.T @ fixed, rotating, atol=1e-9)
    # the Coriolis term is 2 w x v_rel: normal to v_rel, magnitude 2 |w| |r'|
    cor_acc, v_rel = k.fixed.acceleration.coriolis, k.fixed.velocity.relative
    assert abs(cor_acc @ v_rel) <= 1e-9 * (1 + abs(omega) * r_dot**2)
    assert np.linalg.norm(cor_acc) == pytest.approx(2 * abs(omega * r_dot), abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(angle, finite_rate, finite_rate, st.floats(0.01, 5.0), finite_rate, finite_rate)
def test_polar_kinematics_inverts_collar_kinematics(theta, omega, alpha, r, r_dot, r_ddot):
    k = cor.collar_kinematics(theta, omega, alpha, r, r_dot, r_ddot)
    m = cor.polar_kinematics(k.fixed.position, k.fixed.velocity.total, k.fixed.acceleration.total)
    assert math.cos(m.theta) == pytest.approx(math.cos(theta), abs=1e-12)
    assert math.sin(m.theta) == pytest.approx(math.sin(theta), abs=1e-12)
    scale = 1 + abs(omega) ** 2 * r + abs(alpha) * r + abs(omega * r_dot) + abs(r_ddot)
    for got, want in ((m.r, r), (m.r_dot, r_dot), (m.omega, omega)):
        assert got == pytest.approx(want, abs=1e-11 * scale)
    assert m.r_ddot == pytest.approx(r_ddot, abs=1e-11 * scale)
    assert m.alpha == pytest.approx(alpha, abs=1e-11 * scale / r)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(-7.0, 7.0), min_size=1, max_size=8),
    finite_rate,
    finite_rate,
    st.floats(0.01, 2.0),
    st.floats(1.05, 20.0),
)
def test_slotted_link_three_routes_agree(thetas, omega, alpha, r, d_over_r):
    d = r * d_over_r
    theta = np.array(thetas)
    a = cor.slotted_link_closed_form(theta, omega, alpha, r, d)
    b = cor.slotted_link_closure(theta, omega, alpha, r, d)
    # third route: polar kinematics of B - C, B the rim point of the wheel
    pin = cor.collar_kinematics(theta, omega, alpha, r, 0.0, 0.0).fixed
    c = cor.polar_kinematics(pin.position - [d, 0.0], pin.velocity.total, pin.acceleration.total)
    scale = (1 + omega**2 + abs(alpha)) * r / (d - r) * (1 + r / (d - r))
    for x, y, z in (
        (a.omega_rod, b.omega_rod, c.omega),
        (a.stroke_velocity, b.stroke_velocity, c.r_dot),
        (a.alpha_rod, b.alpha_rod, c.alpha),
        (a.stroke_acceleration, b.stroke_acceleration, c.r_ddot),
        (a.stroke, b.stroke, c.r),
    ):
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-10 * scale * max(1.0, d))
        np.testing.assert_allclose(z, x, rtol=0, atol=1e-10 * scale * max(1.0, d))


# ---- errors -------------------------------------------------------------------------------------
def test_non_finite_and_non_numeric_inputs():
    with pytest.raises(InputError, match=r"theta must be finite \(-inf < theta < inf\), got nan"):
        cor.collar_kinematics(np.nan, 0.5, 0.05, 0.25, 0.5, 0.1)
    with pytest.raises(InputError, match=r"r_dot must be finite .*, got inf"):
        cor.collar_kinematics(0.0, 0.5, 0.05, 0.25, [0.5, np.inf], 0.1)
    with pytest.raises(InputError, match=r"omega must be a real number or array, got 'fast'"):
        cor.collar_kinematics(0.0, "fast", 0.05, 0.25, 0.5, 0.1)
    with pytest.raises(InputError, match=r"theta must be finite .*, got -inf"):
        cor.slotted_link_closed_form(-np.inf)
    with pytest.raises(InputError, match=r"alpha must be finite .*, got nan"):
        cor.slotted_link_closure(0.0, alpha=np.nan)
    assert issubclass(InputError, DRSError)


def test_bad_shapes():
    match = r"must broadcast to one shape, got theta \(2,\), .*r \(3,\)"
    with pytest.raises(InputError, match=match):
        cor.collar_kinematics([0.0, 1.0], 0.5, 0.05, [1.0, 2.0, 3.0], 0.5, 0.1)
    with pytest.raises(InputError, match=r"position must have shape \(\.\.\., 2\) .* got \(3,\)"):
        cor.polar_kinematics([1.0, 2.0, 3.0], [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(InputError, match=r"velocity must have shape \(\.\.\., 2\) .* got \(\)"):
        cor.polar_kinematics([1.0, 0.0], 0.0, [0.0, 0.0])
    with pytest.raises(InputError, match=r"must broadcast to one shape"):
        cor.slotted_link_closed_form([0.0, 1.0], omega=[1.0, 2.0, 3.0])


def test_degenerate_geometry():
    with pytest.raises(cor.DegenerateGeometryError, match=r"lies on the pivot \(r = 0\.0 m\)"):
        cor.polar_kinematics([[1.0, 0.0], [0.0, 0.0]], [0.0, 1.0], [0.0, 0.0])
    msg = r"pin B reaches the collar pivot C at theta = 0 \(L = 0\): r = 1\.0 m, d = 1\.0 m; "
    with pytest.raises(cor.DegenerateGeometryError, match=msg + r"need 0 < r < d"):
        cor.slotted_link_closed_form(0.5, r=1.0, d=1.0)
    with pytest.raises(cor.DegenerateGeometryError, match=msg):
        cor.slotted_link_closure(0.5, r=1.0, d=1.0)
    with pytest.raises(
        cor.DegenerateGeometryError,
        match=r"pivot C lies inside the wheel rim: r = 1\.5 m, d = 1\.0 m; need 0 < r < d",
    ):
        cor.slotted_link_position(0.0, r=1.5, d=1.0)
    with pytest.raises(InputError, match=r"r must be > 0 m, got -0\.1"):
        cor.slotted_link_closed_form(0.0, r=-0.1)
    with pytest.raises(InputError, match=r"d must be > 0 m, got 0\.0"):
        cor.slotted_link_closure(0.0, d=0.0)
    assert issubclass(cor.DegenerateGeometryError, AssemblyError)
    assert issubclass(cor.DegenerateGeometryError, DRSError)


def test_example_dataclasses_validate():
    with pytest.raises(ParameterError, match=r"r must be finite, got nan"):
        cor.SlottedLinkExample(r=math.nan)
    with pytest.raises(ParameterError, match=r"omega must be a real number, got 'x'"):
        cor.SlottedLinkExample(omega="x")
    with pytest.raises(ParameterError, match=r"r must be > 0 m, got 0\.0"):
        cor.SlottedLinkExample(r=0.0)
    with pytest.raises(cor.DegenerateGeometryError, match=r"r = 1\.0 m, d = 1\.0 m"):
        cor.SlottedLinkExample(r=1.0)
    with pytest.raises(InputError, match=r"method must be one of \['closed-form', 'closure'\]"):
        cor.SEED_SLOTTED_LINK.solve(0.0, method="newton")
    with pytest.raises(ParameterError, match=r"alpha must be finite, got inf"):
        cor.CollarExample(alpha=math.inf)
    with pytest.raises(ParameterError, match=r"theta must be a real number, got True"):
        cor.CollarExample(theta=True)
    with pytest.raises(ParameterError, match=r"r_max must be > 0, got -1\.0"):
        cor.CollarExample(r_max=-1.0)
    with pytest.raises(InputError, match=r"n_r must be an integer >= 2, got 1"):
        cor.SEED_COLLAR.grid(n_r=1)
    with pytest.raises(dataclasses_frozen_error()):
        cor.SEED_COLLAR.omega = 1.0  # type: ignore[misc]


def dataclasses_frozen_error():
    import dataclasses

    return dataclasses.FrozenInstanceError


def test_plot_errors(tmp_path):
    require_module("matplotlib")
    not_a_dir = tmp_path / "file.png"
    not_a_dir.write_bytes(b"x")
    with pytest.raises(InputError, match=r"plot directory '.*file\.png' exists and is not a dir"):
        plotting.plot_slotted_link(not_a_dir)
    with pytest.raises(InputError, match=r"n must be an integer >= 2, got 1"):
        plotting.plot_slotted_link(tmp_path, n=1)


# ---- CLI ----------------------------------------------------------------------------------------
def _run_json(capsys, *argv):
    assert main(["coriolis", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_cli_collar_default_is_example_1(capsys):
    d = _run_json(capsys, "collar")
    assert d["inputs"]["theta_deg"] == pytest.approx(120.0)
    c, s = -0.5, SQ3 / 2
    v = d["fixed"]["velocity"]["total"]
    assert (v["x"], v["y"]) == (pytest.approx(0.5 * c - 0.125 * s), pytest.approx(0.5 * s - 0.0625))
    assert d["rotating"]["acceleration"]["coriolis"] == {"x": 0.0, "y": pytest.approx(0.5)}
    assert d["rotating"]["acceleration"]["total"]["x"] == pytest.approx(0.0375)
    assert d["plots"] == []


def test_cli_collar_options(capsys):
    rates = "--r 2 --omega 1 --r-dot 0 --r-ddot 0 --alpha 0".split()
    d = _run_json(capsys, "collar", "--angle-deg", "90", *rates)
    # rod along +Y, pure rotation: v = w r (-1, 0), a = -w^2 r (0, 1)
    v, a = d["fixed"]["velocity"]["total"], d["fixed"]["acceleration"]["total"]
    assert (v["x"], v["y"]) == (pytest.approx(-2.0), pytest.approx(0.0, abs=1e-15))
    assert (a["x"], a["y"]) == (pytest.approx(0.0, abs=1e-15), pytest.approx(-2.0))
    d2 = _run_json(capsys, "collar", "--angle", str(math.pi / 2), *rates)
    assert d2["fixed"]["velocity"]["total"]["x"] == pytest.approx(-2.0)
    assert main(["coriolis", "collar"]) == 0
    assert "Only 'a coriolis' (2 omega x v_rel) is the Coriolis term." in capsys.readouterr().out


def test_cli_slotted_link(capsys):
    d = _run_json(capsys, "slotted-link", "--angle-deg", "0,90,180,270")
    np.testing.assert_allclose(d["theta_deg"], [0, 90, 180, 270])
    theta_deg = np.array([0.0, 90.0, 180.0, 270.0])
    np.testing.assert_allclose(d["seed_convention"]["omega_AC"], seed_omega_AC(theta_deg))
    np.testing.assert_allclose(d["seed_convention"]["a_stroke"], seed_a_stroke(theta_deg))
    np.testing.assert_allclose(d["omega_rod"], -seed_omega_AC(theta_deg))
    np.testing.assert_allclose(d["stroke_velocity"], -seed_v_stroke(theta_deg) / 1e3, atol=1e-12)
    dc = _run_json(capsys, "slotted-link", "--angle-deg", "0,90,180,270", "--method", "closure")
    np.testing.assert_allclose(dc["alpha_rod"], d["alpha_rod"], atol=1e-12)
    dd = _run_json(capsys, "slotted-link")
    assert len(dd["theta"]) == 13  # 0..360 every 30 deg
    assert main(["coriolis", "slotted-link", "--seed-units", "--angle", "1.0"]) == 0
    assert "Seed convention" in capsys.readouterr().out


def test_cli_errors(capsys):
    assert main(["coriolis", "slotted-link", "--r", "1", "--d", "1"]) == 2
    assert "drs coriolis: error: the pin B reaches the collar pivot C" in capsys.readouterr().err
    assert main(["coriolis", "collar", "--omega", "nan"]) == 2
    assert "error: omega must be finite, got nan" in capsys.readouterr().err
    assert main(["coriolis", "slotted-link", "--plot", "x", "--dpi", "5"]) == 2
    assert "error: dpi must be in 10..600, got 5" in capsys.readouterr().err


@pytest.mark.parametrize("example", ["collar", "slotted-link"])
@pytest.mark.parametrize("option", [["--set", "Iz_wing=0.08"], ["--params", "drs.toml"]])
def test_cli_examples_take_no_drs_parameters(capsys, example, option):
    """The Coriolis examples are not the DRS mechanism: its --params/--set are not offered."""
    with pytest.raises(SystemExit) as info:
        main(["coriolis", example, *option])
    assert info.value.code == 2
    assert f"unrecognized arguments: {option[0]}" in capsys.readouterr().err


def _assert_png(path):
    data = open(path, "rb").read()
    assert len(data) > 5000 and data[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_plot_writes_pngs(tmp_path, capsys):
    require_module("matplotlib")
    d = _run_json(capsys, "collar", "--plot", str(tmp_path / "maps"), "--dpi", "40")
    names = sorted(p.rsplit("/", 1)[-1] for p in d["plots"])
    assert names == ["collar_ax.png", "collar_ay.png", "collar_vx.png", "collar_vy.png"]
    for p in d["plots"]:
        _assert_png(p)
    d = _run_json(capsys, "slotted-link", "--plot", str(tmp_path), "--dpi", "40")
    assert d["plots"] == [str(tmp_path / "slotted_link.png")]
    _assert_png(d["plots"][0])
