"""``drs-bag trend season.parquet``: each fitted parameter against run time, drift detection
and when a threshold will be crossed (:mod:`drs_model.identify.trend`, docs/identify.md).

Reads the table ``drs-bag fit DIR -o season.parquet`` writes (one row per drs node of each bag:
the run's first log time ``start_ns``, each parameter's value, interval and standard error,
whether determined), orders the runs by time, and for each parameter of each actuator (each
``node`` of the table: the runs of two actuators are two seasons; ``--node`` keeps one) prints
the runs used, the trend (per day: a rate for a linear trend, a percentage for an exponential
one), the run at which a drift began and the run at which it became significant (a CUSUM whose
scale comes from the runs before the drift), and with ``--threshold NAME=VALUE`` the date
the trend reaches it, with its interval. ``--plot FILE.png`` draws each parameter with its
intervals, the trend and its band, the threshold and the predicted crossing.

The options are checked when parsed (argparse's usage error naming the option); the names
``--params`` and ``--threshold`` give are checked against the table once it is read.

Exit status (docs/cli.md): 0 no drift; 1 a drift in one parameter or more; 2 a bad option (a
parameter or ``--node`` the table holds no fit of is one), the table cannot be read, or the
model refuses the trend (fewer than three runs with a value).
"""

from __future__ import annotations

import argparse
import math
import sys
from datetime import UTC, datetime

import numpy as np

from drs_model.cli._common import parameter_names_argument, png_output_path, positive_number
from drs_model.cli.exit_status import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_REFUSED,
    EXIT_UNREADABLE,
    EXIT_USAGE,
)
from drs_model.errors import DRSError, ParameterError
from drs_model.identify.trend import DECISION, MIN_RUNS, MODELS, trend
from drs_model.overrides import assignment_overrides
from drs_ros.bag.season.fit_report import dumps
from drs_ros.errors import DRSRosError, UsageError
from drs_ros.timestamps import seconds_from_ns

DAY_S = 86400.0


class TrendInputError(DRSRosError):
    """The season table cannot be read or is no season table."""


def threshold_argument(item: str) -> str:
    """``--threshold NAME=VALUE``: a finite number."""
    try:
        ((name, value),) = assignment_overrides([item]).items()
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace("--set", "--threshold")) from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"the threshold of {name} must be finite, got {value!r}")
    return item


def min_runs_argument(text: str) -> int:
    """``--min-runs``: an integer >= 3 (a trend needs three runs)."""
    try:
        runs = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if runs < 3:
        raise argparse.ArgumentTypeError(f"must be >= 3 (a trend needs three runs), got {runs}")
    return runs


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("table", help="the season's table (drs-bag fit DIR -o season.parquet)")
    ap.add_argument(
        "--params",
        dest="names",
        type=parameter_names_argument,
        metavar="NAME,...",
        help="the parameters (default: every fitted one)",
    )
    ap.add_argument(
        "--node",
        metavar="NAME",
        help="the actuator, by its drs node's fully "
        "qualified name or its name (default: each node of the table)",
    )
    ap.add_argument(
        "--threshold",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        type=threshold_argument,
        help="predict when NAME reaches VALUE (repeatable)",
    )
    ap.add_argument(
        "--model",
        choices=MODELS,
        default="auto",
        help="linear, exponential, or auto: exponential when every value is > 0 (default)",
    )
    ap.add_argument(
        "--decision",
        type=positive_number,
        default=DECISION,
        help="the drift "
        "CUSUM's decision interval [standard deviations], > 0; higher: fewer false "
        f"alarms, later flags (default {DECISION:g})",
    )
    ap.add_argument(
        "--min-runs",
        type=min_runs_argument,
        default=MIN_RUNS,
        help=f"runs before the first drift test, >= 3 (default {MIN_RUNS})",
    )
    ap.add_argument(
        "--plot",
        metavar="FILE.png",
        type=png_output_path,
        help="draw each parameter over the season",
    )
    ap.add_argument("--json", action="store_true", help="print the result as JSON")


def read_season(path: str) -> dict:
    """The table's columns as lists (pyarrow)."""
    import pyarrow.parquet as pq

    try:
        return pq.read_table(path).to_pydict()
    except (OSError, ValueError) as exc:
        raise TrendInputError(f"cannot read the season table {path!r}: {exc}") from exc


def fitted_names(cols: dict) -> list[str]:
    """The parameters the table holds (a ``NAME_std`` column with its ``NAME``)."""
    return [c[: -len("_std")] for c in cols if c.endswith("_std") and c[: -len("_std")] in cols]


def node_seasons(cols: dict, node: str | None = None) -> list[tuple[str | None, dict]]:
    """The table split by actuator: ``(node, its rows' columns)`` per drs node of the ``node``
    column, in the order first seen (rows of no node, a bag another tool wrote, are one season
    of their own); with ``node``, only the one it names (fully qualified, or its last part).

    Raises
    ------
    UsageError
        ``node`` names no node of the table, or several.
    """
    nodes = list(cols.get("node") or [None] * len(cols["start_ns"]))
    held = list(dict.fromkeys(nodes))
    if node is not None:
        wanted = node if node.startswith("/") else f"/{node}"
        found = [n for n in held if n == wanted] or [
            n for n in held if n is not None and n.rsplit("/", 1)[-1] == node
        ]
        if len(found) != 1:
            names = ", ".join(str(n) for n in held)
            raise UsageError(
                f"--node {node!r} names {'several' if found else 'none'} of the "
                f"nodes of the table: {names}"
            )
        held = found
    out = []
    for name in held:
        rows = [i for i, n in enumerate(nodes) if n == name]
        out.append((name, {c: [v[i] for i in rows] for c, v in cols.items()}))
    return out


def _series(cols: dict, name: str):
    start = np.array([math.nan if v is None else v for v in cols["start_ns"]], dtype=float)
    value = np.array([math.nan if v is None else v for v in cols[name]], dtype=float)
    std = np.array([math.nan if v is None else v for v in cols[f"{name}_std"]], dtype=float)
    det = np.array([bool(v) for v in cols.get(f"{name}_determined", [True] * len(value))])
    value[~det] = math.nan
    return seconds_from_ns(start), value, std


def _date(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "never (at this trend)"
    return datetime.fromtimestamp(seconds, UTC).strftime("%Y-%m-%d %H:%M")


def analyse(cols: dict, names, thresholds: dict, args, node: str | None = None) -> list[dict]:
    """One result per parameter of one actuator's season (``node``): the trend, its drift, its
    crossing."""
    bags = list(cols.get("bag", []))
    out = []
    for name in names:
        tau, value, std = _series(cols, name)
        tr = trend(
            name, tau, value, std, args.model, thresholds.get(name), args.decision, args.min_runs
        )
        used = np.flatnonzero(np.isfinite(tau) & np.isfinite(value) & np.isfinite(std))
        used = used[np.argsort(tau[used], kind="stable")]
        row = {
            "parameter": name,
            "node": node,
            "model": tr.model,
            "runs": int(tr.tau.size),
            "slope_per_day": tr.slope * DAY_S,
            "slope_std_per_day": tr.slope_std * DAY_S,
            "drift": {1: "rising", -1: "falling", 0: "none"}[tr.direction],
            "onset_run": None,
            "onset_bag": None,
            "detected_run": None,
            "detected_bag": None,
            "probability": None,
            "threshold": tr.threshold,
            "crossing": None,
            "trend": tr,
        }
        if tr.detected is not None:
            row["detected_run"] = int(tr.detected) + 1
            row["detected_bag"] = bags[used[tr.detected]] if bags else None
            row["probability"] = float(tr.probability[tr.detected])
            row["onset_run"] = int(tr.onset) + 1
            row["onset_bag"] = bags[used[tr.onset]] if bags else None
        if tr.crossing is not None:
            lo, mid, hi = (tr.origin + c for c in tr.crossing)
            row["crossing"] = {
                "low": _date(lo),
                "median": _date(mid),
                "high": _date(hi),
                "days_after_last_run": [(c - tr.tau[-1]) / DAY_S for c in tr.crossing],
            }
        out.append(row)
    return out


def format_text(rows: list[dict]) -> str:
    lines = []
    for r in rows:
        k, unit = (100.0, " %/day") if r["model"] == "exponential" else (1.0, " /day")
        of = "" if r["node"] is None else f" of {r['node']}"
        lines.append(
            f"{r['parameter']}{of}: {r['runs']} runs, {r['model']} trend "
            f"{k * r['slope_per_day']:+.4g}{unit} (+- "
            f"{k * abs(r['slope_std_per_day']):.2g})"
        )
        if r["detected_run"] is None:
            lines.append("  drift: none")
        else:
            lines.append(
                f"  drift: {r['drift']}, from run {r['onset_run']} ({r['onset_bag']}), "
                f"significant at run {r['detected_run']} ({r['detected_bag']}); the "
                f"line's P = {r['probability']:.6f}"
            )
        if r["crossing"] is not None:
            c = r["crossing"]
            days = ", ".join(
                "never" if not math.isfinite(d) else f"{d:+.1f}" for d in c["days_after_last_run"]
            )
            lines.append(
                f"  reaches {r['threshold']:.6g} on {c['median']} (95 %: {c['low']} "
                f"to {c['high']}; days after the last run: {days})"
            )
    return "\n".join(lines)


def plot(rows: list[dict], seasons: dict, path: str) -> None:
    """Each result of ``rows`` in its panel; ``seasons``: node -> its columns."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(rows), 1, figsize=(9, 2.8 * len(rows) + 0.5), squeeze=False)
    for ax, r in zip(axes[:, 0], rows, strict=True):
        tr = r["trend"]
        name, cols = r["parameter"], seasons[r["node"]]
        day = tr.tau / DAY_S
        tau, value, _ = _series(cols, name)
        lo = np.array([math.nan if v is None else v for v in cols[f"{name}_lower"]], float)
        hi = np.array([math.nan if v is None else v for v in cols[f"{name}_upper"]], float)
        ok = np.isfinite(value) & np.isfinite(tau)
        order = np.argsort(tau[ok])
        x = (tau[ok][order] - tr.origin) / DAY_S
        v, l_, h = value[ok][order], lo[ok][order], hi[ok][order]
        ax.errorbar(
            x,
            v,
            yerr=[v - l_, h - v],
            fmt="o",
            ms=3,
            color="0.3",
            lw=0.8,
            label="fit, 95 % interval",
        )
        end = (
            day[-1]
            if tr.crossing is None or not math.isfinite(tr.crossing[2])
            else max(day[-1], tr.crossing[2] / DAY_S)
        )
        grid = np.linspace(0.0, end * 1.05 + 1e-9, 200)
        ax.plot(grid, tr.fitted(grid * DAY_S), "-", color="C0", label=f"{tr.model} trend")
        if tr.detected is not None:
            ax.axvline(
                day[tr.detected],
                color="C3",
                ls="--",
                lw=1,
                label=f"drift significant (run {tr.detected + 1})",
            )
        if tr.threshold is not None:
            ax.axhline(tr.threshold, color="C1", lw=1, label="threshold")
            if tr.crossing is not None and math.isfinite(tr.crossing[2]):
                ax.axvspan(
                    tr.crossing[0] / DAY_S,
                    tr.crossing[2] / DAY_S,
                    color="C1",
                    alpha=0.2,
                    label="crossing, 95 %",
                )
        ax.set_ylabel(name)
        if r["node"] is not None:
            ax.set_title(r["node"], fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("days since the first run")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _checked_names(cols: dict, args) -> tuple[list[str], dict[str, float]]:
    """The parameters to trend and their thresholds, checked against the table."""
    known = fitted_names(cols)
    names = args.names or known
    unknown = [n for n in names if n not in known]
    if unknown:
        raise UsageError(f"--params: the table holds no fit of {unknown}; it holds {known}")
    thresholds = assignment_overrides(args.threshold)
    extra = sorted(set(thresholds) - set(names))
    if extra:
        raise UsageError(f"--threshold for {extra}, which is not among the parameters {names}")
    return names, thresholds


def run(args: argparse.Namespace, prog: str = "drs-bag trend") -> int:
    try:
        cols = read_season(args.table)
        if "start_ns" not in cols:
            raise TrendInputError(f"{args.table!r} is no season table (no start_ns column)")
        names, thresholds = _checked_names(cols, args)
        seasons = dict(node_seasons(cols, args.node))
        rows = [
            r
            for node, season in seasons.items()
            for r in analyse(season, names, thresholds, args, node)
        ]
        if args.plot:
            plot(rows, seasons, args.plot)
    except UsageError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except (DRSRosError, OSError) as exc:  # the table, or the plot's file
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_UNREADABLE
    except DRSError as exc:  # the model refuses (too few runs, an exponential of a value <= 0)
        print(f"{prog}: error: the model refuses the trend: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    if args.json:
        print(dumps([{k: v for k, v in r.items() if k != "trend"} for r in rows]))
    else:
        print(format_text(rows))
    return EXIT_FAILED if any(r["detected_run"] is not None for r in rows) else EXIT_OK


__all__ = [
    "TrendInputError",
    "add_arguments",
    "analyse",
    "node_seasons",
    "read_season",
    "run",
    "threshold_argument",
]
