"""``drs inverse`` (piston force and reactions at given times) and ``drs peak`` (peak force)."""

from __future__ import annotations

import argparse

import numpy as np

from ..constraints import PSI3, S
from ..errors import InputError
from ..inverse import (
    INVERSE_METHODS,
    REACTION_NAMES,
    force_ratio,
    inverse_dynamics,
    manoeuvre_force,
    manoeuvre_state,
    peak_force,
    refine_extremum,
    static_force_ratio,
)
from ..kinematics import stroke_limits
from ..params import SEED_LITERAL_IZ_WING
from ._common import Output, add_common, float_list, key_values, load_params, table


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("inverse", help="piston force (and joint reactions) along the manoeuvre")
    add_common(p)
    p.add_argument("--method", choices=sorted(INVERSE_METHODS), default="newton-euler")
    p.add_argument("--time", type=float_list, required=True, metavar="T[,T...]", help="times [s]")
    p.set_defaults(func=run_inverse)

    p = sub.add_parser("peak", help="peak piston force, its time and stroke, force ratio range")
    add_common(p)
    p.add_argument("--method", choices=sorted(INVERSE_METHODS), default="fused")
    p.add_argument("--samples", type=int, default=5001, help="grid before the Brent refinement")
    p.set_defaults(func=run_peak)


def run_inverse(args) -> Output:
    params = load_params(args)
    t = np.asarray(args.time, dtype=float)
    if not np.all(np.isfinite(t)):
        raise InputError("time must be finite")
    _, state = manoeuvre_state(t, params)
    res = inverse_dynamics(state, params, args.method)
    d = {
        "method": res.method,
        "t": t,
        "s": state.q[:, S],
        "psi3": state.q[:, PSI3],
        "piston_force": res.piston_force,
    }
    headers = ["t [s]", "s [m]", "psi3 [rad]", "F [N]"]
    cols = [t, state.q[:, S], state.q[:, PSI3], res.piston_force]
    if res.reactions is not None:
        d["reactions"] = dict(res.reactions)
        headers += [f"{k} [{'N m' if k == 'Tp' else 'N'}]" for k in REACTION_NAMES]
        cols += [res.reactions[k] for k in REACTION_NAMES]
    if res.multipliers is not None:
        d["multipliers"] = res.multipliers
        headers += ["lambda1 [N]", "lambda2 [N]"]
        cols += [res.multipliers[:, 0], res.multipliers[:, 1]]
    rows = list(zip(*cols, strict=True))
    return Output(d, f"inverse dynamics ({res.method})\n" + table(headers, rows))


def run_peak(args) -> Output:
    params = load_params(args)
    pk = peak_force(params, args.method, n=args.samples)
    # every extremum refined from its grid sample as the peak is (refine_extremum)
    t = np.linspace(0.0, params.T_total, max(3, int(args.samples)))
    low = refine_extremum(lambda tt: manoeuvre_force(tt, params, args.method), t, "min")

    def ratio(tt):
        return force_ratio(tt, params, args.method)

    ratio_lo, ratio_hi = refine_extremum(ratio, t, "min"), refine_extremum(ratio, t, "max")
    s_min, s_max = stroke_limits(params)
    s = np.linspace(s_min, s_max, 201)

    def static(ss):
        return static_force_ratio(ss, params)

    static_lo, static_hi = refine_extremum(static, s, "min"), refine_extremum(static, s, "max")
    d = {
        "method": args.method,
        "Iz_wing": params.Iz_wing,
        "seed_literal_Iz_wing": bool(np.isclose(params.Iz_wing, SEED_LITERAL_IZ_WING)),
        "peak_force": pk.force,
        "peak_time": pk.time,
        "peak_stroke": pk.stroke,
        "peak_psi3": pk.psi3,
        "force_min": low.value,
        "force_min_time": low.x,
        "force_ratio_min": ratio_lo.value,
        "force_ratio_max": ratio_hi.value,
        "static_force_ratio_min": static_lo.value,
        "static_force_ratio_max": static_hi.value,
    }
    text = key_values(
        [
            ("Iz_wing", params.Iz_wing, "kg m^2"),
            ("peak piston force", pk.force, "N"),
            ("  at time", pk.time, "s"),
            ("  at stroke", pk.stroke, "m"),
            ("  at psi3", pk.psi3, "rad"),
            ("lowest piston force", low.value, "N"),
            ("  at time", low.x, "s"),
            ("F/|F_air| along the manoeuvre", f"{ratio_lo.value:.6g} .. {ratio_hi.value:.6g}", "-"),
            (
                "F/|F_air| static, along the stroke",
                f"{static_lo.value:.6g} .. {static_hi.value:.6g}",
                "",
            ),
        ]
    )
    title = f"peak piston force ({args.method}; --set Iz_wing=0.08 for the seed's literal)"
    return Output(d, title + "\n" + text)
