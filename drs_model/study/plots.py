"""Figures of a study: each result's histogram, and the sensitivity ranking (Sobol' indices)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

# the one matplotlib set-up of drs_model: Agg figures without pyplot, 256-colour PNGs
from ..plotting import _figure, _save

#: How each result is shown: column -> (label, scale to the shown unit, unit).
DISPLAY = {
    "peak_force": ("peak piston force", 1e-3, "kN"),
    "lowest_force": ("lowest piston force", 1e-3, "kN"),
    "dead_centre_margin": ("closed stop to dead centre", 1e3, "mm"),
    "opening_time": ("opening time", 1e3, "ms"),
    "closing_time": ("closing time", 1e3, "ms"),
    "gap_error_closed": ("gap error, closed", 1e3, "mm"),
    "gap_error_open": ("gap error, open", 1e3, "mm"),
}


def histograms(columns: dict[str, np.ndarray], path: Path, title: str) -> Path:
    """One histogram per result of :data:`DISPLAY` (finite values only), as a PNG at ``path``."""
    names = list(DISPLAY)
    fig = _figure((14.0, 6.5), 110)
    axes = fig.subplots(2, 4)
    for ax, name in zip(axes.ravel(), names, strict=False):
        label, scale, unit = DISPLAY[name]
        x = columns[name][np.isfinite(columns[name])] * scale
        ax.hist(x, bins=40, color="tab:blue", alpha=0.85)
        ax.set_title(f"{label} (n = {x.size})", fontsize=10)
        ax.set_xlabel(unit)
    axes.ravel()[-1].axis("off")
    fig.suptitle(title)
    _save(fig, path)
    return path


def sensitivity(indices: dict, fields, path: Path, title: str) -> Path:
    """Bars of the first-order and total Sobol' index of each field, per result, the fields sorted
    by total index, as a PNG at ``path``. ``indices``: result name -> :class:`.Indices`."""
    names = [n for n in DISPLAY if indices.get(n) is not None]
    cols = min(4, max(1, len(names)))
    rows = max(1, -(-len(names) // cols))
    fig = _figure((3.6 * cols, 0.45 * len(fields) * rows + 2.2), 110)
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax, name in zip(axes.ravel(), names, strict=False):
        ind = indices[name]
        order = np.argsort(ind.total_order)
        y = np.arange(len(fields))
        ax.barh(y + 0.2, ind.total_order[order], height=0.4, label="total", color="tab:orange")
        ax.barh(y - 0.2, ind.first_order[order], height=0.4, label="first order", color="tab:blue")
        ax.set_yticks(y, [fields[i] for i in order])
        ax.set_xlim(0.0, 1.05)
        ax.set_title(f"{DISPLAY[name][0]} ({ind.groups} groups)", fontsize=10)
    for ax in axes.ravel()[len(names) :]:
        ax.axis("off")
    if names:
        axes.ravel()[0].legend(loc="lower right", fontsize=8)
    fig.suptitle(title)
    _save(fig, path)
    return path
