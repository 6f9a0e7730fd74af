"""``drs study SPEC.toml``: a tolerance study on Dask (docs/study.md)."""

from __future__ import annotations

import argparse

from ._common import Output, add_json, output_path, table


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "study",
        help="sample parameter distributions and evaluate each sample on Dask (docs/study.md)",
    )
    add_json(p)
    p.add_argument("spec", metavar="SPEC.toml", help="the study: distributions, sampler, scene")
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--jobs",
        type=int,
        metavar="N",
        help="worker processes of the embedded Dask cluster (default: the cores)",
    )
    where.add_argument(
        "--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://host:8786"
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        default="study",
        type=output_path,
        help="directory of study.parquet, histograms.png, sensitivity.png",
    )
    p.add_argument(
        "--chunk",
        type=int,
        default=None,
        metavar="ROWS",
        help="samples per Dask task (default 128)",
    )
    p.set_defaults(func=run_study_command)


def run_study_command(args) -> Output:
    from ..study import read_spec, run_study, summary, write_outputs
    from ..study.run import DEFAULT_CHUNK, spec_summary

    spec = read_spec(args.spec)
    result = run_study(
        spec,
        jobs=args.jobs,
        scheduler=args.scheduler,
        chunk=DEFAULT_CHUNK if args.chunk is None else args.chunk,
    )
    paths = write_outputs(result, args.output)
    data = summary(result)
    data["spec"] = spec_summary(spec)
    data["files"] = {k: str(v) for k, v in paths.items()}
    return Output(data, render(data))


def render(data: dict) -> str:
    """The printed summary: counts, each result's spread, the ranking of each result's fields."""
    from ..study.plots import DISPLAY

    lines = [f"drs study: {data['runs']} samples, {data['failed']} without results"]
    for reason, count in data["reasons"].items():
        lines.append(f"  {count:6d}  {reason}")
    rows = []
    for name, s in data["results"].items():
        if s is None or name not in DISPLAY:
            continue
        label, scale, unit = DISPLAY[name]
        rows.append(
            [
                f"{label} [{unit}]",
                s["n"],
                *(s[k] * scale for k in ("mean", "std", "min", "p1", "p50", "p99", "max")),
            ]
        )
    lines.append(
        table(
            ["result", "n", "mean", "std", "min", "1 %", "median", "99 %", "max"],
            rows,
            fmt="{:.5g}",
        )
    )
    for name, counts in data["forward_runs"].items():
        lines.append(
            f"{name.replace('_', ' ')}: " + ", ".join(f"{k} {v}" for k, v in counts.items())
        )
    if data["sensitivity"]:
        lines.append("sensitivity (Sobol' total index, first order in brackets), largest first:")
        for name, ranks in data["sensitivity"].items():
            top = ", ".join(
                f"{r['field']} {r['total_order']:.2f} ({r['first_order']:.2f})" for r in ranks[:4]
            )
            lines.append(f"  {DISPLAY[name][0]}: {top}")
    lines.append("files: " + ", ".join(data["files"].values()))
    return "\n".join(lines)
