"""``drs excite NAME,...``: an excitation for the parameters named, by default one that leaves
none of them looser than the seed's manoeuvre of the same length (the worst ratio; ``--criterion
D`` for D-optimal)
(:mod:`drs_model.identify.excitation`, docs/identify.md): the trajectory as a
FollowJointTrajectory goal file (``-o goal.yaml``) and a plot, with the standard errors it
predicts beside those of the seed's manoeuvre over the same time.

The goal is the hand-over to ROS, which the model does not speak: ``ros2 action send_goal``
sends it to the node's action, and ``drs-bag from-goal goal.yaml -o DIR``
(:mod:`drs_ros.bag.from_goal`, the ros extra) writes it as a bag that ``drs-bag play`` sends to
the node's trajectory command. The options are checked when parsed (argparse's usage error
naming the option); a parameter the design cannot serve is the model's refusal, with its
reason."""

from __future__ import annotations

import argparse
import json

import numpy as np

from ..errors import InputError
from ..params import FORCE_LIMIT_DEFAULT_N
from ._common import (
    Output,
    add_common,
    fit_names_argument,
    load_both,
    output_file_type,
    png_output_path,
    positive_integer,
    positive_number,
    table,
)

#: What ``drs excite --help`` and the report say of the bag form of the goal.
BAG_RECIPE = (
    "drs-bag from-goal GOAL.yaml -o DIR [--node NAME] writes the goal as a bag that "
    "drs-bag play DIR sends to the node (the ros extra; docs/identify.md)"
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "excite",
        help="design an excitation for parameters to identify (docs/identify.md)",
        description="A multisine stroke within the stroke, rate, force and flow limits that "
        "makes the parameters named as well determined as it can, each against the seed's "
        "manoeuvre of the same length; written as a FollowJointTrajectory goal (-o) for ros2 "
        "action send_goal.",
        epilog=f"As a bag for drs-bag play: {BAG_RECIPE}.",
    )
    add_common(p)
    p.add_argument(
        "names",
        metavar="NAME,...",
        type=fit_names_argument,
        help="the parameters to identify, e.g. m_pist,Iz_wing,F_drag_open,F_down_closed",
    )
    p.add_argument(
        "--fidelity",
        choices=("rigid", "quasi-static", "hydraulic"),
        default="hydraulic",
        help="the rung the fit will run on (default hydraulic)",
    )
    p.add_argument(
        "--duration", type=positive_number, default=0.3, help="the run's length [s] (0.3)"
    )
    p.add_argument("--harmonics", type=positive_integer, default=10, help="of the multisine (10)")
    p.add_argument(
        "--criterion",
        choices=("worst-ratio", "D"),
        default="worst-ratio",
        help="worst-ratio: the largest ratio of a parameter's standard error to the "
        "seed manoeuvre's, least; D: log det of the information, largest (a trade "
        "of one parameter for another scores well) (default worst-ratio)",
    )
    p.add_argument(
        "--point-spacing",
        type=positive_number,
        default=4e-3,
        help="between the trajectory's points [s] (0.004)",
    )
    p.add_argument(
        "--sample-period",
        type=positive_number,
        default=1e-3,
        help="of the recorded states the fit will read [s] (0.001)",
    )
    p.add_argument(
        "--noise", type=positive_number, default=1e-5, help="stroke sensor noise [m] (1e-5)"
    )
    p.add_argument(
        "--force-limit",
        type=positive_number,
        default=FORCE_LIMIT_DEFAULT_N,
        help="the node's force limit [N]; the supply's force applies too "
        f"({FORCE_LIMIT_DEFAULT_N:g})",
    )
    p.add_argument("--seed", type=int, default=0, help="of the optimiser's starts (0)")
    p.add_argument("--starts", type=positive_integer, default=12, help="optimiser starts (12)")
    p.add_argument(
        "-o",
        "--output",
        metavar="GOAL.yaml",
        type=output_file_type(".yaml", ".yml"),
        help="write the goal file (for "
        "ros2 action send_goal, or drs-bag from-goal to make a bag of it)",
    )
    p.add_argument("--joint", default="drs_piston", help="the piston joint (drs_piston)")
    p.add_argument(
        "--plot",
        metavar="PNG",
        type=png_output_path,
        help="the stroke and rate of the excitation and of "
        "the seed's manoeuvre, as the rung runs them",
    )
    p.set_defaults(func=run_excite)


def _write_goal(path: str, goal: dict) -> None:
    try:
        import yaml
    except ImportError:  # JSON is YAML
        text = json.dumps(goal, indent=1)
    else:
        text = yaml.safe_dump(goal, sort_keys=False)
    with open(path, "w") as f:
        f.write(text)


def _plot(path: str, t, excitation, seed, rung: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    for (s, sd, _), label, style in (
        (excitation, "excitation", "-"),
        (seed, "seed manoeuvre", "--"),
    ):
        ax.plot(t * 1e3, s * 1e3, style, label=label)
        bx.plot(t * 1e3, sd, style, label=label)
    ax.set_ylabel("stroke [mm]")
    bx.set_ylabel("stroke rate [m/s]")
    bx.set_xlabel("time [ms]")
    ax.set_title(f"as the {rung} rung runs them")
    for a in (ax, bx):
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_excite(args: argparse.Namespace) -> Output:
    from ..identify.excitation import default_limits, design_excitation
    from ..identify.information import (
        information,
        rung_motion,
        seed_manoeuvre_information,
        standard_errors,
    )
    from ..identify.parameters import fit_parameter

    p, hp = load_both(args)
    names = args.names  # checked when parsed (fit_names_argument)
    limits = default_limits(p, hp, args.force_limit)
    ex = design_excitation(
        names,
        p,
        hp,
        rung=args.fidelity,
        duration=args.duration,
        harmonics=args.harmonics,
        sample_period=args.sample_period,
        point_spacing=args.point_spacing,
        limits=limits,
        stroke_noise=args.noise,
        seed=args.seed,
        starts=args.starts,
        criterion=args.criterion,
    )
    # both as the rung runs them (the hydraulic rung's servo and valve slow both down)
    length = float(ex.t[-1])
    ran = rung_motion(
        p, hp, args.fidelity, length, args.sample_period, (ex.times, ex.strokes, ex.rates)
    )
    std = standard_errors(information(names, *ran, p, hp, args.fidelity, args.noise), names, p, hp)
    seed_std = standard_errors(
        seed_manoeuvre_information(
            names, p, hp, args.fidelity, length, args.sample_period, args.noise
        ),
        names,
        p,
        hp,
    )
    files = {}
    try:
        if args.plot:
            seed = rung_motion(p, hp, args.fidelity, length, args.sample_period)
            _plot(args.plot, ex.t, ran, seed, args.fidelity)
            files["plot"] = args.plot
        if args.output:
            _write_goal(args.output, ex.goal(args.joint))
            files["goal"] = args.output
    except OSError as exc:  # a file named by -o or --plot
        raise InputError(f"cannot write: {exc}") from None
    data = {
        "parameters": [
            {
                "name": n,
                "unit": fit_parameter(n, p, hp).unit,
                "std_excitation": float(a),
                "std_seed_manoeuvre": float(b),
            }
            for n, a, b in zip(names, std, seed_std, strict=True)
        ],
        "rung": args.fidelity,
        "criterion": args.criterion,
        "duration_s": length,
        "points": len(ex.times),
        "log_det_information": ex.log_det,
        "limits": {"margin_m": limits.margin, "rate_m_per_s": limits.rate, "force_n": limits.force},
        "peaks": {
            "stroke_m": [float(ex.s.min()), float(ex.s.max())],
            "rate_m_per_s": float(np.abs(ex.sd).max()),
            "force_n": float(np.abs(ex.force).max()),
        },
        "files": files,
    }
    return Output(data, render(data))


def render(data: dict) -> str:
    rows = [
        [
            d["name"],
            d["unit"],
            d["std_excitation"],
            d["std_seed_manoeuvre"],
            d["std_seed_manoeuvre"] / d["std_excitation"],
        ]
        for d in data["parameters"]
    ]
    lim, peak = data["limits"], data["peaks"]
    lines = [
        f"drs excite: {data['points']} points over {data['duration_s']:g} s on the "
        f"{data['rung']} rung, criterion {data['criterion']} (log det of the information "
        f"{data['log_det_information']:.4g})",
        "standard errors the fit would give (equation error; both run on the rung, the same "
        "noise and length):",
        table(["parameter", "unit", "excitation", "seed manoeuvre", "ratio"], rows, "{:.4g}"),
        f"limits kept: stroke {1e3 * peak['stroke_m'][0]:.3f}..{1e3 * peak['stroke_m'][1]:.3f} "
        f"mm ({1e3 * lim['margin_m']:.1f} mm from the stops), rate {peak['rate_m_per_s']:.3f} "
        f"of {lim['rate_m_per_s']:.3f} m/s, force {peak['force_n']:.0f} of "
        f"{lim['force_n']:.0f} N",
    ]
    lines += [f"wrote {what}: {path}" for what, path in data["files"].items()]
    goal = data["files"].get("goal")
    if goal:
        lines.append(f"as a bag for drs-bag play: drs-bag from-goal {goal} -o DIR [--node NAME]")
    return "\n".join(lines)
