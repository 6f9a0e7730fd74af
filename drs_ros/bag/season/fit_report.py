"""What ``drs-bag fit`` shows and writes: the estimates' table with their intervals, what was
not determined and why, identifiability, residuals; the JSON document; one table row per bag
(a season's Parquet); the figure of measured against fitted signals."""

from __future__ import annotations

import json
import math
from pathlib import Path

from drs_model.identify.results import FitResult
from drs_ros.bag.read.nodes import node_note


def _node_line(node) -> str:
    if node is None:  # a bag another tool wrote: its topics come from --topic-map
        return (
            "node: none named by the bag (no node parameters, no topics record): topics by "
            "their default names or --topic-map"
        )
    return node_note(node)


STAGE_TEXT = {"equation": "equation error", "output": "output error"}


def _num(x: float) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.6g}"


def format_text(bag: str, result: FitResult, measured) -> str:
    """The printed report of one bag's fit."""
    stages = " then ".join(dict.fromkeys(STAGE_TEXT[s.stage] for s in result.stages)) or "none"
    level = f"{100 * result.level:g} %"
    lines = [
        f"fit of {bag} on the {result.rung} rung ({stages}; {level} intervals)",
        _node_line(measured.node),
        f"model parameters: {measured.params_source}",
    ]
    head = (
        f"{'parameter':<24} {'unit':<11} {'start':>12} {'estimate':>13} "
        f"{level + ' interval':>29}  {'stage':<8} interval"
    )
    lines += [head, "-" * len(head)]
    for e in result.estimates:
        interval = f"[{_num(e.lower)}, {_num(e.upper)}]" if e.determined else "not determined"
        lines.append(
            f"{e.name:<24} {e.unit:<11} {_num(e.start):>12} {_num(e.value):>13} "
            f"{interval:>29}  {e.stage:<8} {e.interval}"
        )
    refused = [e for e in result.estimates if not e.determined]
    if refused:
        lines.append("not determined (no value reported):")
        lines += [f"  {e.name}: {e.reason}" for e in refused]
    for s in result.stages:
        ident = s.identifiability
        what = s.label if s.label == STAGE_TEXT[s.stage] else f"{s.label} ({STAGE_TEXT[s.stage]})"
        lines.append(
            f"{what}, {s.seconds:.2f} s: rank "
            f"{ident.rank} of {len(ident.names)}, condition number of the "
            f"information {ident.condition_number:.3g}"
        )
        for group in ident.groups:
            lines.append(f"  cannot be separated: {', '.join(group)}")
        for a, b, c in ident.pairs:
            lines.append(f"  trade off: {a} and {b} (correlation {c:+.4f})")
        for sig in s.signals:
            d = sig.summary()
            lines.append(
                f"  residual {d['signal']}: rms {d['residual_rms']:.4g} {d['unit']}, "
                f"max {d['residual_max']:.4g} {d['unit']} ({d['samples']} samples)"
            )
        lines += [f"  note: {n}" for n in s.notes]
    lines += [f"note: {n}" for n in (*measured.notes, *result.notes)]
    return "\n".join(lines)


def document(bag: str, result: FitResult, measured) -> dict:
    """The JSON document of one bag's fit."""
    doc = {
        "bag": str(bag),
        "node": None if measured.node is None else measured.node.name,
        "model_parameters": measured.params_source,
        "topics": measured.topics,
        "start_ns": measured.start_ns,
        **result.to_dict(),
    }
    doc["notes"] = [*measured.notes, *doc["notes"]]
    return doc


def dumps(doc) -> str:
    """Strict JSON (NaN as null)."""

    def clean(x):
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        return x

    return json.dumps(clean(doc), indent=2, allow_nan=False)


def row_columns(result: FitResult) -> dict:
    """A season table's columns of one fit: per parameter its value, interval, standard error,
    whether determined and by which stage; per signal the residual RMS."""
    out = {"rung": result.rung, "level": result.level}
    for e in result.estimates:
        out[e.name] = e.value
        out[f"{e.name}_lower"] = e.lower
        out[f"{e.name}_upper"] = e.upper
        out[f"{e.name}_std"] = e.std
        out[f"{e.name}_determined"] = e.determined
        out[f"{e.name}_stage"] = e.stage
    for sig in result.signals:
        out[f"residual_{sig.name}"] = sig.residual_rms
    return out


def plot(result: FitResult, path: str | Path, title: str = "") -> Path:
    """Measured (points) against fitted (line) signals, one panel each, and the residuals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    signals = result.signals
    if not signals:
        raise ValueError("the fit has no signals to plot")
    fig, axes = plt.subplots(
        len(signals),
        2,
        figsize=(11, 2.4 * len(signals) + 0.6),
        squeeze=False,
        gridspec_kw={"width_ratios": [3, 1.4]},
    )
    for (ax, res), sig in zip(axes, signals, strict=True):
        ax.plot(sig.t, sig.measured, ".", ms=2.5, color="0.45", label="measured")
        ax.plot(sig.t, sig.fitted, "-", lw=1.2, color="C0", label="fitted")
        ax.set_ylabel(f"{sig.name} [{sig.unit}]")
        ax.grid(alpha=0.3)
        res.plot(sig.t, sig.measured - sig.fitted, ".", ms=2.5, color="C3")
        res.set_ylabel(f"residual [{sig.unit}]")
        res.grid(alpha=0.3)
    axes[0][0].legend(loc="best", fontsize=8)
    axes[-1][0].set_xlabel("run time [s]")
    axes[-1][1].set_xlabel("run time [s]")
    fig.suptitle(title or f"fit on the {result.rung} rung: measured against fitted")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


__all__ = ["document", "dumps", "format_text", "plot", "row_columns"]
