"""``drs forward``: forward dynamics under a piston force (constant, step, or the manoeuvre's)."""

from __future__ import annotations

import argparse
import math

import numpy as np

from .. import kinematics as kin
from ..errors import InputError
from ..forward import (
    COMPILED_METHODS,
    FORMULATIONS,
    SCIPY_METHODS,
    ManoeuvreForce,
    StepForce,
    simulate,
)
from ._common import Output, add_common, load_params, table


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "forward",
        help="forward dynamics: the motion under a piston force",
        description="Integrate the forward dynamics from rest (at --s0, default the closed "
        "stroke) under a constant force [N], a step 'step:F0,F1,T' or 'manoeuvre' (the "
        "inverse-dynamics force of the open-hold-close manoeuvre, whose exact solution is the "
        "profile: the table then shows the error).",
    )
    add_common(p)
    p.add_argument("--force", default="manoeuvre", help="F [N] | manoeuvre | step:F0,F1,T")
    p.add_argument("--formulation", default="psi3", choices=sorted(FORMULATIONS))
    p.add_argument(
        "--method",
        default="DOP853",
        choices=sorted(SCIPY_METHODS) + sorted(COMPILED_METHODS),
        help="scipy solver, or a compiled one (psi3 only; needs drs[fast])",
    )
    p.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance")
    p.add_argument("--atol", type=float, default=None, help="absolute tolerance (default scaled)")
    p.add_argument("--max-step", type=float, default=math.inf, help="maximum step [s]")
    p.add_argument("--t-end", type=float, default=None, help="end time [s] (default T_total)")
    p.add_argument("--s0", type=float, default=None, help="initial stroke at rest [m]")
    p.add_argument("--samples", type=int, default=11, help="rows of the output table")
    p.set_defaults(func=run_forward)


def parse_force(text: str, params):
    """``"manoeuvre"``, a number [N], or ``"step:F0,F1,T"``."""
    text = text.strip()
    if text == "manoeuvre":
        return ManoeuvreForce(params)
    if text.startswith("step:"):
        try:
            f0, f1, ts = (float(x) for x in text[5:].split(","))
        except ValueError:
            raise InputError(f"--force step expects step:F0,F1,T, got {text!r}") from None
        return StepForce(f0, f1, ts)
    try:
        value = float(text)
    except ValueError:
        raise InputError(
            f"--force must be a number [N], 'manoeuvre' or 'step:F0,F1,T', got {text!r}"
        ) from None
    if not math.isfinite(value):
        raise InputError(f"--force must be finite, got {value!r}")
    return value


def run_forward(args) -> Output:
    params = load_params(args)
    force = parse_force(args.force, params)
    t_end = params.T_total if args.t_end is None else float(args.t_end)
    if not (math.isfinite(t_end) and t_end > 0.0):
        raise InputError(f"--t-end must be a finite number > 0 s, got {args.t_end!r}")
    if args.samples < 2:
        raise InputError(f"--samples must be >= 2, got {args.samples!r}")
    s0 = kin.stroke_limits(params)[0] if args.s0 is None else float(args.s0)
    q0 = kin.solve_position(s0, params)
    t = np.linspace(0.0, t_end, args.samples)
    options = {}
    if args.atol is not None:
        options["atol"] = args.atol
    sol = simulate(
        args.formulation,
        force,
        (0.0, t_end),
        params=params,
        initial=(q0, np.zeros(3)),
        method=args.method,
        rtol=args.rtol,
        max_step=args.max_step,
        t_eval=t,
        **options,
    )
    gap = kin.gap(sol.q, params)
    data = {
        "formulation": sol.formulation,
        "method": sol.method,
        "rtol": args.rtol,
        "t": sol.t,
        "s": sol.s,
        "psi1": sol.q[:, 1],
        "psi3": sol.psi3,
        "s_dot": sol.qd[:, 0],
        "psi3_dot": sol.qd[:, 2],
        "gap": gap,
        "constraint_residual": sol.residual,
        "nfev": sol.nfev,
        "nsteps": sol.nsteps,
    }
    headers = ["t [ms]", "s [mm]", "psi3 [deg]", "gap [mm]"]
    cols = [sol.t * 1e3, sol.s * 1e3, np.degrees(sol.psi3), gap * 1e3]
    if isinstance(force, ManoeuvreForce):
        err = sol.s - force.profile(sol.t)[0]
        data["s_error"] = err
        headers.append("s - profile [m]")
        cols.append(err)
    if sol.q.shape[0] and np.any(sol.residual):
        headers.append("|Phi| [m]")
        cols.append(sol.residual)
    rows = list(zip(*cols, strict=True))
    text = (
        f"formulation {sol.formulation}, {sol.method}, rtol {args.rtol:g}: "
        f"{sol.nsteps} steps, {sol.nfev} evaluations\n" + table(headers, rows)
    )
    return Output(data, text)
