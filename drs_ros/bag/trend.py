"""``drs-bag trend season.parquet``: each fitted parameter against run time, drift detection
and when a threshold will be crossed (:mod:`drs_model.identify.trend`, docs/identify.md).

Reads the table ``drs-bag fit DIR -o season.parquet`` writes (one row per bag: the run's first
log time ``start_ns``, each parameter's value, interval and standard error, whether
determined), orders the runs by time, and for each parameter prints the runs used, the trend
(per day: a rate for a linear trend, a percentage for an exponential one), the run at which a
drift became significant, and with ``--threshold NAME=VALUE`` the date the trend reaches it,
with its interval. ``--plot FILE.png`` draws each parameter with its intervals, the trend and
its band, the threshold and the predicted crossing.

Exit status: 0 no drift; 1 a drift in one parameter or more; 2 the table cannot be read, a
parameter is unknown, or an option is invalid.
"""

from __future__ import annotations

import argparse
import math
import sys
from datetime import UTC, datetime

import numpy as np

from drs_model.errors import DRSError
from drs_model.identify.trend import ALPHA, MIN_RUNS, MODELS, trend
from drs_model.overrides import assignment_overrides

from ..errors import DRSRosError
from .fit_report import dumps

DAY_S = 86400.0


class TrendInputError(DRSRosError):
    """The season table cannot be read or holds no such parameter."""


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("table", help="the season's table (drs-bag fit DIR -o season.parquet)")
    ap.add_argument("--params", dest="names", help="the parameters (default: every fitted one)")
    ap.add_argument("--threshold", action="append", default=[], metavar="NAME=VALUE",
                    help="predict when NAME reaches VALUE (repeatable)")  # fmt: skip
    ap.add_argument("--model", choices=MODELS, default="auto", help="linear, exponential, or "
                    "auto: exponential when every value is > 0 (default)")  # fmt: skip
    ap.add_argument("--alpha", type=float, default=ALPHA, help="false-alarm probability of "
                    f"each run's drift test (default {ALPHA:g})")  # fmt: skip
    ap.add_argument("--min-runs", type=int, default=MIN_RUNS,
                    help=f"runs before the first drift test (default {MIN_RUNS})")
    ap.add_argument("--plot", metavar="FILE.png", help="draw each parameter over the season")
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


def _series(cols: dict, name: str):
    start = np.array([math.nan if v is None else v for v in cols["start_ns"]], dtype=float)
    value = np.array([math.nan if v is None else v for v in cols[name]], dtype=float)
    std = np.array([math.nan if v is None else v for v in cols[f"{name}_std"]], dtype=float)
    det = np.array([bool(v) for v in cols.get(f"{name}_determined", [True] * len(value))])
    value[~det] = math.nan
    return start * 1e-9, value, std


def _date(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "never (at this trend)"
    return datetime.fromtimestamp(seconds, UTC).strftime("%Y-%m-%d %H:%M")


def analyse(cols: dict, names, thresholds: dict, args) -> list[dict]:
    """One result per parameter: the trend, its drift, its crossing."""
    bags = list(cols.get("bag", []))
    out = []
    for name in names:
        tau, value, std = _series(cols, name)
        tr = trend(name, tau, value, std, args.model, thresholds.get(name), args.alpha,
                   args.min_runs)  # fmt: skip
        used = np.flatnonzero(np.isfinite(tau) & np.isfinite(value) & np.isfinite(std))
        used = used[np.argsort(tau[used], kind="stable")]
        row = {"parameter": name, "model": tr.model, "runs": int(tr.tau.size),
               "slope_per_day": tr.slope * DAY_S, "slope_std_per_day": tr.slope_std * DAY_S,
               "drift": {1: "rising", -1: "falling", 0: "none"}[tr.direction],
               "detected_run": None, "detected_bag": None, "probability": None,
               "threshold": tr.threshold, "crossing": None, "trend": tr}  # fmt: skip
        if tr.detected is not None:
            row["detected_run"] = int(tr.detected) + 1
            row["detected_bag"] = bags[used[tr.detected]] if bags else None
            row["probability"] = float(tr.probability[tr.detected])
        if tr.crossing is not None:
            lo, mid, hi = (tr.origin + c for c in tr.crossing)
            row["crossing"] = {"low": _date(lo), "median": _date(mid), "high": _date(hi),
                               "days_after_last_run": [(c - tr.tau[-1]) / DAY_S
                                                       for c in tr.crossing]}  # fmt: skip
        out.append(row)
    return out


def format_text(rows: list[dict]) -> str:
    lines = []
    for r in rows:
        k, unit = (100.0, " %/day") if r["model"] == "exponential" else (1.0, " /day")
        lines.append(f"{r['parameter']}: {r['runs']} runs, {r['model']} trend "
                     f"{k * r['slope_per_day']:+.4g}{unit} (+- "
                     f"{k * abs(r['slope_std_per_day']):.2g})")  # fmt: skip
        if r["detected_run"] is None:
            lines.append("  drift: none")
        else:
            lines.append(f"  drift: {r['drift']}, significant from run {r['detected_run']} "
                         f"({r['detected_bag']}), P = {r['probability']:.6f}")  # fmt: skip
        if r["crossing"] is not None:
            c = r["crossing"]
            days = ", ".join("never" if not math.isfinite(d) else f"{d:+.1f}"
                             for d in c["days_after_last_run"])  # fmt: skip
            lines.append(f"  reaches {r['threshold']:.6g} on {c['median']} (95 %: {c['low']} "
                         f"to {c['high']}; days after the last run: {days})")  # fmt: skip
    return "\n".join(lines)


def plot(rows: list[dict], cols: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(rows), 1, figsize=(9, 2.8 * len(rows) + 0.5), squeeze=False)
    for ax, r in zip(axes[:, 0], rows, strict=True):
        tr = r["trend"]
        name = r["parameter"]
        day = tr.tau / DAY_S
        tau, value, _ = _series(cols, name)
        lo = np.array([math.nan if v is None else v for v in cols[f"{name}_lower"]], float)
        hi = np.array([math.nan if v is None else v for v in cols[f"{name}_upper"]], float)
        ok = np.isfinite(value) & np.isfinite(tau)
        order = np.argsort(tau[ok])
        x = (tau[ok][order] - tr.origin) / DAY_S
        v, l_, h = value[ok][order], lo[ok][order], hi[ok][order]
        ax.errorbar(x, v, yerr=[v - l_, h - v], fmt="o", ms=3, color="0.3", lw=0.8,
                    label="fit, 95 % interval")  # fmt: skip
        end = day[-1] if tr.crossing is None or not math.isfinite(tr.crossing[2]) else max(
            day[-1], tr.crossing[2] / DAY_S)  # fmt: skip
        grid = np.linspace(0.0, end * 1.05 + 1e-9, 200)
        ax.plot(grid, tr.fitted(grid * DAY_S), "-", color="C0", label=f"{tr.model} trend")
        if tr.detected is not None:
            ax.axvline(day[tr.detected], color="C3", ls="--", lw=1,
                       label=f"drift significant (run {tr.detected + 1})")  # fmt: skip
        if tr.threshold is not None:
            ax.axhline(tr.threshold, color="C1", lw=1, label="threshold")
            if tr.crossing is not None and math.isfinite(tr.crossing[2]):
                ax.axvspan(tr.crossing[0] / DAY_S, tr.crossing[2] / DAY_S, color="C1", alpha=0.2,
                           label="crossing, 95 %")  # fmt: skip
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("days since the first run")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(args: argparse.Namespace, prog: str = "drs-bag trend") -> int:
    try:
        cols = read_season(args.table)
        if "start_ns" not in cols:
            raise TrendInputError(f"{args.table!r} is no season table (no start_ns column)")
        known = fitted_names(cols)
        names = [n.strip() for n in args.names.split(",")] if args.names else known
        unknown = [n for n in names if n not in known]
        if unknown:
            raise TrendInputError(f"the table holds no fit of {unknown}; it holds {known}")
        thresholds = assignment_overrides(args.threshold)
        extra = sorted(set(thresholds) - set(names))
        if extra:
            raise TrendInputError(f"--threshold for {extra}, which is not among {names}")
        rows = analyse(cols, names, thresholds, args)
        if args.plot:
            plot(rows, cols, args.plot)
    except (DRSError, DRSRosError, OSError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(dumps([{k: v for k, v in r.items() if k != "trend"} for r in rows]))
    else:
        print(format_text(rows))
    return 1 if any(r["detected_run"] is not None for r in rows) else 0


__all__ = ["TrendInputError", "add_arguments", "analyse", "read_season", "run"]
