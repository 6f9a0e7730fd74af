"""``drs limits``, ``drs kinematics``, ``drs profile`` and ``drs demo`` (model only)."""

from __future__ import annotations

import argparse
import math

import numpy as np

from .. import kinematics as kin
from ..constraints import singularity_measure
from ..errors import InputError
from ..profile import drs_manoeuvre
from ._common import (
    Output,
    add_common,
    float_list,
    key_values,
    load_params,
    png_output_path,
    table,
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("limits", help="stroke and flap-angle limits, singular strokes")
    add_common(p)
    p.set_defaults(func=run_limits)

    p = sub.add_parser("kinematics", help="configuration, velocity ratio and points at a stroke")
    add_common(p)
    grp = p.add_mutually_exclusive_group(required=True)
    grp.add_argument("--stroke", type=float, metavar="S", help="piston stroke [m]")
    grp.add_argument("--flap-angle", type=float, metavar="PSI3", help="flap angle psi3 [rad]")
    grp.add_argument("--gap", type=float, metavar="G", help="flap gap [m]")
    p.add_argument("--branch", type=int, choices=(1, 2), default=1, help="assembly branch")
    p.set_defaults(func=run_kinematics)

    p = sub.add_parser("profile", help="the open-hold-close manoeuvre at given times")
    add_common(p)
    p.add_argument("--time", type=float_list, required=True, metavar="T[,T...]", help="times [s]")
    p.set_defaults(func=run_profile)

    p = sub.add_parser("draw", help="draw the mechanism at some strokes into a PNG")
    add_common(p)
    p.add_argument(
        "--stroke",
        type=float_list,
        metavar="S[,S...]",
        help="strokes [m] (default: closed, half-way, open)",
    )
    p.add_argument(
        "--out",
        default="mechanism.png",
        type=png_output_path,
        help="PNG path (its directory must exist)",
    )
    p.set_defaults(func=run_draw)

    p = sub.add_parser("demo", help="the manoeuvre end to end, model only (limits + table)")
    add_common(p)
    p.add_argument("--samples", type=int, default=11, help="rows of the manoeuvre table")
    p.set_defaults(func=run_demo)


def limits_data(params) -> dict:
    s_min, s_max = kin.stroke_limits(params)
    psi_c, psi_o = kin.flap_angle_limits(params)
    sing = kin.singular_strokes(params)
    dead = kin.dead_centre(params)
    q = kin.solve_position(np.array([s_min, s_max]), params)
    tau = kin.velocity_ratio(q, params)
    return {
        "s_min": s_min,
        "s_max": s_max,
        "stroke": s_max - s_min,
        "psi3_closed": psi_c,
        "psi3_open": psi_o,
        "psi3_closed_deg": math.degrees(psi_c),
        "psi3_open_deg": math.degrees(psi_o),
        "gap_closed": params.gap_closed,
        "gap_open": params.gap_open,
        "singular_strokes": sing,
        "dead_centre": dead,
        "closed_to_dead_centre": s_min - dead,
        "dpsi3_ds_closed": tau[0, 2],
        "dpsi3_ds_open": tau[1, 2],
    }


def run_limits(args) -> Output:
    d = limits_data(load_params(args))
    text = key_values(
        [
            ("s_min (closed, gap 10 mm)", d["s_min"], "m"),
            ("s_max (open, gap 50 mm)", d["s_max"], "m"),
            ("stroke", d["stroke"], "m"),
            ("psi3 closed", d["psi3_closed"], f"rad ({d['psi3_closed_deg']:.6f} deg)"),
            ("psi3 open", d["psi3_open"], f"rad ({d['psi3_open_deg']:.6f} deg)"),
            ("singular strokes", ", ".join(f"{v:.9g}" for v in d["singular_strokes"]), "m"),
            ("s_min - dead centre", d["closed_to_dead_centre"], "m"),
            ("dpsi3/ds closed", d["dpsi3_ds_closed"], "rad/m"),
            ("dpsi3/ds open", d["dpsi3_ds_open"], "rad/m"),
        ]
    )
    return Output(d, text)


def run_kinematics(args) -> Output:
    params = load_params(args)
    if args.stroke is not None:
        if not math.isfinite(args.stroke):
            raise InputError(f"stroke must be finite, got {args.stroke!r}")
        q = kin.solve_position(args.stroke, params, args.branch)
    elif args.flap_angle is not None:
        q = kin.solve_position_from_flap_angle(args.flap_angle, params, args.branch)
    else:
        psi3 = kin.flap_angle_for_gap(args.gap, params)
        q = kin.solve_position_from_flap_angle(psi3, params, args.branch)
    pts = kin.point_positions(q, params)
    meas_s = float(singularity_measure(q, params, "s"))
    tau = kin.velocity_ratio(q, params, check=False) if meas_s > 0 else np.full(3, np.nan)
    d = {
        "branch": args.branch,
        "q": {"s": q[0], "psi1": q[1], "psi3": q[2]},
        "gap": float(kin.gap(q, params)),
        "velocity_ratio": {"dpsi1_ds": tau[1], "dpsi3_ds": tau[2]},
        "singularity_measure_s": meas_s,
        "singularity_measure_psi3": float(singularity_measure(q, params, "psi3")),
        "distance_to_singular_stroke": float(kin.distance_to_singularity(q[0], params)),
        "points": {k: v for k, v in pts.items()},
    }
    lines = key_values(
        [
            ("s", q[0], "m"),
            ("psi1", q[1], "rad"),
            ("psi3", q[2], "rad"),
            ("gap", d["gap"], "m"),
            ("dpsi1/ds", tau[1], "rad/m"),
            ("dpsi3/ds", tau[2], "rad/m"),
            ("|cos(psi1-psi3)|", meas_s, "- (0 = singular)"),
            ("to nearest singular stroke", d["distance_to_singular_stroke"], "m"),
        ]
    )
    pts_table = table(("point", "x [m]", "y [m]"), [(k, v[0], v[1]) for k, v in pts.items()])
    return Output(d, lines + "\n\n" + pts_table)


def run_profile(args) -> Output:
    params = load_params(args)
    t = np.array(args.time)
    if not np.all(np.isfinite(t)):
        raise InputError("time must be finite")
    m = drs_manoeuvre(params)
    s, v, a = m.evaluate(t)
    q = kin.solve_position(s, params)
    g = kin.gap(q, params)
    d = {"t": t, "s": s, "s_dot": v, "s_ddot": a, "psi3": q[:, 2], "gap": g}
    rows = list(zip(t, s, v, a, q[:, 2], g, strict=True))
    text = table(("t [s]", "s [m]", "s' [m/s]", "s'' [m/s^2]", "psi3 [rad]", "gap [m]"), rows)
    return Output(d, text)


def run_demo(args) -> Output:
    params = load_params(args)
    lim = run_limits(args)
    n = max(2, int(args.samples))
    t = np.linspace(0.0, params.T_total, n)
    m = drs_manoeuvre(params)
    s, v, a = m.evaluate(t)
    q = kin.solve_position(s, params)
    g = kin.gap(q, params)
    rows = list(zip(t * 1e3, s * 1e3, v, a, np.degrees(q[:, 2]), g * 1e3, strict=True))
    tab = table(("t [ms]", "s [mm]", "s' [m/s]", "s'' [m/s^2]", "psi3 [deg]", "gap [mm]"), rows)
    d = {"limits": lim.data, "t": t, "s": s, "s_dot": v, "s_ddot": a, "psi3": q[:, 2], "gap": g}
    return Output(d, "DRS limits\n" + lim.text + "\n\nOpen-hold-close manoeuvre\n" + tab)


def run_draw(args) -> Output:
    from ..plotting import mechanism_figure

    params = load_params(args)
    lo, hi = kin.stroke_limits(params)
    strokes = args.stroke if args.stroke else [lo, 0.5 * (lo + hi), hi]
    path = mechanism_figure(params, strokes, args.out)
    return Output({"path": str(path), "strokes": strokes}, f"wrote {path}")
