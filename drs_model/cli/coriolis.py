"""``drs coriolis collar`` and ``drs coriolis slotted-link`` (seed 000, rotating-frame kinematics).

Options are SI and radians unless the name says ``-deg``; defaults are the seed's example data.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from .. import coriolis as cor
from .. import plotting
from ..errors import InputError
from ._common import Output, add_json, float_list, output_path, table


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "coriolis", help="rotating-frame kinematics of seed 000 (collar, slotted link)"
    )
    csub = p.add_subparsers(dest="coriolis_command", required=True, metavar="EXAMPLE")

    ex = cor.SEED_COLLAR
    q = csub.add_parser(
        "collar",
        help="collar sliding along a rotating rod (examples 1-2): every velocity and "
        "acceleration term in fixed and rotating axes",
    )
    add_json(q)
    q.add_argument("--omega", type=float, default=ex.omega, help="rod angular velocity [rad/s]")
    q.add_argument("--alpha", type=float, default=ex.alpha, help="rod angular accel. [rad/s^2]")
    q.add_argument("--r", type=float, default=ex.r, help="distance pivot -> collar [m]")
    q.add_argument("--r-dot", type=float, default=ex.r_dot, help="sliding velocity [m/s]")
    q.add_argument("--r-ddot", type=float, default=ex.r_ddot, help="sliding accel. [m/s^2]")
    grp = q.add_mutually_exclusive_group()
    grp.add_argument("--angle", type=float, help="rod angle [rad] (default: 120 deg)")
    grp.add_argument("--angle-deg", type=float, help="rod angle [deg] (default: 120)")
    q.add_argument("--r-max", type=float, default=ex.r_max, help="map range of r for --plot [m]")
    q.add_argument(
        "--plot",
        metavar="DIR",
        type=output_path,
        help="write example 2's four contour+surface PNGs",
    )
    q.add_argument("--dpi", type=int, default=100, help="PNG resolution (with --plot)")
    q.set_defaults(func=run_collar)

    link = cor.SEED_SLOTTED_LINK
    q = csub.add_parser(
        "slotted-link",
        help="wheel pin driving a rod through a pivoting collar (example 3)",
    )
    add_json(q)
    q.add_argument("--r", type=float, default=link.r, help="wheel radius A -> pin B [m]")
    q.add_argument("--d", type=float, default=link.d, help="distance A -> collar pivot C [m]")
    q.add_argument("--omega", type=float, default=link.omega, help="wheel ang. velocity [rad/s]")
    q.add_argument("--alpha", type=float, default=link.alpha, help="wheel ang. accel. [rad/s^2]")
    grp = q.add_mutually_exclusive_group()
    grp.add_argument(
        "--angle-deg",
        type=float_list,
        metavar="DEG[,DEG...]",
        help="wheel angles [deg] (default: 0 to 360 every 30)",
    )
    grp.add_argument("--angle", type=float_list, metavar="RAD[,RAD...]", help="wheel angles [rad]")
    q.add_argument(
        "--method",
        choices=sorted(cor.SLOTTED_LINK_METHODS),
        default="closed-form",
        help="closed-form expressions or the seed's closure equations at C",
    )
    q.add_argument(
        "--seed-units",
        action="store_true",
        help="also print the seed's convention (mm, deg, clockwise-positive rates)",
    )
    q.add_argument(
        "--plot", metavar="DIR", type=output_path, help="write slotted_link.png over 0..360 deg"
    )
    q.add_argument("--dpi", type=int, default=100, help="PNG resolution (with --plot)")
    q.set_defaults(func=run_slotted_link)


def _angle(args, default_rad):
    if args.angle is not None:
        return args.angle
    if args.angle_deg is not None:
        return np.radians(args.angle_deg)
    return default_rad


def _dpi(value: int) -> int:
    if not 10 <= value <= 600:
        raise InputError(f"dpi must be in 10..600, got {value!r}")
    return value


def _vec(v) -> dict:
    return {"x": float(v[0]), "y": float(v[1])}


def _frame_data(frame: cor.FrameKinematics) -> dict:
    return {
        "position": _vec(frame.position),
        "velocity": {k: _vec(v) for k, v in frame.velocity._asdict().items()},
        "acceleration": {k: _vec(v) for k, v in frame.acceleration._asdict().items()},
    }


def run_collar(args) -> Output:
    dpi = _dpi(args.dpi)
    angle = _angle(args, cor.SEED_COLLAR.theta)
    example = cor.CollarExample(
        omega=args.omega,
        alpha=args.alpha,
        r=args.r,
        r_dot=args.r_dot,
        r_ddot=args.r_ddot,
        theta=float(angle),
        r_max=args.r_max,
    )
    kin = example.kinematics()
    data = {
        "inputs": {
            "theta": example.theta,
            "theta_deg": math.degrees(example.theta),
            "omega": example.omega,
            "alpha": example.alpha,
            "r": example.r,
            "r_dot": example.r_dot,
            "r_ddot": example.r_ddot,
        },
        "fixed": _frame_data(kin.fixed),
        "rotating": _frame_data(kin.rotating),
        "plots": [],
    }
    rows = []
    for name, unit, fixed, rot in (
        [("position", "m", kin.fixed.position, kin.rotating.position)]
        + [
            (f"v {k}", "m/s", getattr(kin.fixed.velocity, k), getattr(kin.rotating.velocity, k))
            for k in cor.VelocityTerms._fields
        ]
        + [
            (
                f"a {k}",
                "m/s^2",
                getattr(kin.fixed.acceleration, k),
                getattr(kin.rotating.acceleration, k),
            )
            for k in cor.AccelerationTerms._fields
        ]
    ):
        rows.append((name, fixed[0], fixed[1], rot[0], rot[1], unit))
    text = (
        f"Collar at theta = {math.degrees(example.theta):.6g} deg, r = {example.r:.6g} m "
        "(fixed X, Y; rotating x along the rod, y = k x x)\n"
        + table(("term", "X", "Y", "x (rod)", "y (rod)", "unit"), rows)
        + "\nOnly 'a coriolis' (2 omega x v_rel) is the Coriolis term."
    )
    if args.plot:
        paths = plotting.plot_collar_maps(args.plot, example, dpi=dpi)
        data["plots"] = [str(p) for p in paths]
        text += "\n\nwrote " + ", ".join(str(p) for p in paths)
    return Output(data, text)


def run_slotted_link(args) -> Output:
    dpi = _dpi(args.dpi)
    link = cor.SlottedLinkExample(r=args.r, d=args.d, omega=args.omega, alpha=args.alpha)
    theta = np.asarray(_angle(args, np.radians(np.arange(0.0, 361.0, 30.0))), dtype=float)
    motion = link.solve(theta, args.method)
    seed = cor.to_seed_convention(motion)
    data = {
        "inputs": {
            "r": link.r,
            "d": link.d,
            "omega": link.omega,
            "alpha": link.alpha,
            "method": args.method,
        },
        **{k: np.atleast_1d(v) for k, v in motion._asdict().items()},
        "theta_deg": np.degrees(np.atleast_1d(theta)),
        "seed_convention": {k: np.atleast_1d(v) for k, v in seed.items()},
        "plots": [],
    }
    rows = list(
        zip(
            np.degrees(np.atleast_1d(theta)),
            np.degrees(np.atleast_1d(motion.rod_angle)),
            *(np.atleast_1d(getattr(motion, k)) for k in motion._fields[2:]),
            strict=True,
        )
    )
    text = (
        f"Slotted link ({args.method}): r = {link.r:g} m, d = {link.d:g} m, "
        f"omega = {link.omega:g} rad/s, alpha = {link.alpha:g} rad/s^2; rates CCW positive, "
        "L = |CB|\n"
        + table(
            (
                "theta [deg]",
                "rod [deg]",
                "L [m]",
                "w_rod [rad/s]",
                "L' [m/s]",
                "a_rod [rad/s^2]",
                "L'' [m/s^2]",
            ),
            rows,
        )
    )
    if args.seed_units:
        seed_rows = list(zip(*(np.atleast_1d(v) for v in seed.values()), strict=True))
        text += (
            "\n\nSeed convention (mm, clockwise-positive omega_AC, alpha_AC; v_stroke > 0 when "
            "L shrinks)\n"
            + table(
                ("theta [deg]", "omega_AC", "v_stroke [mm/s]", "alpha_AC", "a_stroke [mm/s^2]"),
                seed_rows,
            )
        )
    if args.plot:
        paths = plotting.plot_slotted_link(args.plot, link, dpi=dpi)
        data["plots"] = [str(p) for p in paths]
        text += "\n\nwrote " + ", ".join(str(p) for p in paths)
    return Output(data, text)
