"""``drs fidelity``: the fidelity ladder measured on the standard scenes (docs/fidelity.md)."""

from __future__ import annotations

import argparse
import math
import sys

from ..errors import InputError
from ..fidelity.ladder import DEFAULT_TOLERANCES, QUANTITIES, measure, needed_rung
from ..fidelity.scenes import SCENES, STANDARD_SCENES
from ._common import Output, add_common, load_both, png_output_path, table

#: What a scene's subscribers ask for, for the "needs" table: gap only (a lap simulation), and
#: everything (a supervisor or hydraulic sizing test).
ASKS = {"gap": ("gap",), "all": tuple(QUANTITIES)}


#: The chambers' table: each chamber's lowest pressure and time at the vapour pressure.
FLOOR_HEADERS = (
    "scene",
    "run",
    "lowest p_A [Pa]",
    "lowest p_B [Pa]",
    "at floor A [s]",
    "at floor B [s]",
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "fidelity",
        help="the fidelity ladder: each rung's error against the hydraulic one, and its cost",
        description="Run the standard scenes (open-hold-close, force step, supply loss, the "
        "1 kHz gap stream of a lap) on every rung; print each rung's largest error against the "
        "hydraulic reference (gap, stroke, force, opening and closing times), its cost per "
        "simulated second, and the cheapest rung each scene needs for the tolerances.",
    )
    add_common(p)
    p.add_argument("--dt", type=float, default=1e-3, help="physics step [s] (default 1 kHz)")
    for name, unit in QUANTITIES.items():
        p.add_argument(
            f"--{name}-tol",
            type=float,
            default=DEFAULT_TOLERANCES[name],
            help=f"tolerance on the {name} error [{unit}] (default {DEFAULT_TOLERANCES[name]:g})",
        )
    p.add_argument(
        "--scene",
        action="append",
        choices=list(SCENES),
        default=None,
        metavar="NAME",
        help=f"run only this standard scene (repeatable; default all: {', '.join(SCENES)})",
    )
    p.add_argument(
        "--lap",
        type=float,
        default=None,
        metavar="SECONDS",
        help="shorten the gap stream's 90 s lap to SECONDS (a quick look)",
    )
    p.add_argument(
        "--plot",
        metavar="PNG",
        type=png_output_path,
        help="write the chart (e.g. docs/img/fidelity.png)",
    )
    p.add_argument("--dpi", type=int, default=100, help="PNG resolution (with --plot)")
    p.set_defaults(func=run_fidelity)


def run_fidelity(args: argparse.Namespace) -> Output:
    params, hydraulic = load_both(args)
    if not (math.isfinite(args.dt) and 0.0 < args.dt <= 0.01):
        raise InputError(f"--dt must be in (0, 0.01] s, got {args.dt!r}")
    tolerances = {name: getattr(args, f"{name}_tol") for name in QUANTITIES}
    for name, value in tolerances.items():
        if not (math.isfinite(value) and value > 0.0):
            raise InputError(f"--{name}-tol must be a finite number > 0, got {value!r}")

    def progress(label):
        if not args.json:
            print(f"[fidelity] {label}", file=sys.stderr, flush=True)

    scenes = STANDARD_SCENES if not args.scene else tuple(SCENES[n] for n in args.scene)
    rows = measure(
        params, args.dt, scenes=scenes, lap_seconds=args.lap, progress=progress, hydraulic=hydraulic
    )
    scenes = list(dict.fromkeys(r.scene for r in rows))
    needs = {
        scene: {ask: needed_rung(rows, scene, qs, tolerances) for ask, qs in ASKS.items()}
        for scene in scenes
    }
    data = {
        "dt": args.dt,
        "tolerances": tolerances,
        "rows": [
            {
                "scene": r.scene,
                "run": r.label,
                "rung": r.rung,
                "errors": r.errors,
                "cost_per_simulated_second": r.cost_per_second,
                "opening_time": r.opening,
                "closing_time": r.closing,
                "refused": r.refused,
                "chambers": r.chambers,
            }
            for r in rows
        ],
        "needs": needs,
        "plot": None,
    }
    if args.plot:
        from ..plotting import plot_fidelity

        data["plot"] = str(plot_fidelity(rows, args.plot, dpi=args.dpi))
    headers = (
        "scene",
        "run",
        "gap [m]",
        "stroke [m]",
        "force [N]",
        "opening [s]",
        "closing [s]",
        "cost [s/s]",
    )
    body = []
    for r in rows:
        if r.refused:
            body.append((r.scene, r.label, "refused", "", "", "", "", ""))
            continue
        e = r.errors or {}
        body.append(
            (r.scene, r.label, *(e.get(q, "reference") for q in QUANTITIES), r.cost_per_second)
        )
    need_rows = [(s, *(needs[s][a] or "none" for a in ASKS)) for s in scenes]
    floor_keys = ("lowest_pressure_a", "lowest_pressure_b", "time_at_floor_a", "time_at_floor_b")
    floor_rows = [
        (r.scene, r.label, *(r.chambers[k] for k in floor_keys)) for r in rows if r.chambers
    ]
    tol_text = ", ".join(f"{k} {v:g} {QUANTITIES[k]}" for k, v in tolerances.items())
    text = (
        table(headers, body, fmt="{:.3g}")
        + f"\n\ncheapest run within the tolerances ({tol_text}):\n"
        + table(("scene", "gap only", "everything"), need_rows)
        + "\n\nchambers (lowest pressure, time with a vapour cavity open):\n"
        + table(FLOOR_HEADERS, floor_rows, fmt="{:.4g}")
        + (f"\n\nchart: {data['plot']}" if data["plot"] else "")
    )
    return Output(data, text)
