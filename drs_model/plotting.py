"""Figures of the mechanism (matplotlib, imported lazily so the model does not need it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import kinematics as kin
from .params import DRSParams


def mechanism_figure(p: DRSParams, strokes, path: str | Path, title: str | None = None) -> Path:
    """Draw the mechanism at the given strokes [m] (one colour each) and save a PNG at ``path``.

    Shows the FIA box, the pylon, the main wing, the piston A-B, the link B-C, the flap outline,
    the gap T-R, the workspace traces of B and C and the fixed points A, D.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    strokes = np.atleast_1d(np.asarray(strokes, dtype=float))
    q = kin.solve_position(strokes, p)
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    ax.add_patch(
        plt.Rectangle(
            (0, 0),
            p.box_width,
            p.box_height,
            fill=False,
            ls="--",
            color="0.6",
            label=f"FIA box {p.box_width:g} x {p.box_height:g} m",
        )
    )
    pylon = np.asarray(p.pylon_outline)
    ax.fill(pylon[:, 0], pylon[:, 1], color="0.85", label="pylon")
    mw = kin.main_wing_outline(p)
    ax.fill(mw[:, 0], mw[:, 1], color="tab:red", alpha=0.35, label="main wing")
    tr = kin.workspace_traces(p, 40)
    ax.plot(*tr["B"].T, ":", color="c", lw=2, label="trace of B")
    ax.plot(*tr["C"].T, ":", color="navy", lw=2, label="trace of C")
    colors = plt.cm.viridis(np.linspace(0.0, 0.85, len(strokes)))
    for qi, col in zip(q, colors, strict=True):
        pts = kin.point_positions(qi, p)
        fl = kin.flap_outline(qi, p)
        gap_mm = 1e3 * float(kin.gap(qi, p))
        ax.fill(fl[:, 0], fl[:, 1], color=col, alpha=0.45)
        ax.plot(*np.stack([pts["A"], pts["B"]]).T, "-", color=col, lw=4)
        ax.plot(*np.stack([pts["B"], pts["C"]]).T, "-", color="k", lw=2.5)
        ax.plot(*np.stack([pts["D"], pts["C"]]).T, "-", color=col, lw=1.5)
        ax.plot([pts["T"][0]] * 2, [pts["R"][1], pts["T"][1]], "-", color="g", lw=1)
        ax.plot(*pts["T"], "o", color="g", ms=4)
        ax.plot(*pts["G3"], "m.", ms=6)
        ax.annotate(
            f"s = {1e3 * qi[0]:.2f} mm, gap {gap_mm:.1f} mm",
            pts["T"],
            textcoords="offset points",
            xytext=(-150, 6),
            fontsize=8,
            color=col,
        )
    pts = kin.point_positions(q[0], p)
    for name in ("A", "D", "R"):
        ax.plot(*pts[name], "s" if name != "R" else "o", color="b" if name != "R" else "g", ms=6)
        ax.annotate(name, pts[name], textcoords="offset points", xytext=(5, -10))
    for name in ("B", "C"):
        ax.annotate(name, pts[name], textcoords="offset points", xytext=(6, 2))
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (ground frame, rearwards)")
    ax.set_ylabel("y [m] (up)")
    ax.set_title(title or "DRS mechanism: piston A-B, link B-C, flap about D")
    ax.legend(loc="upper left", fontsize=7)
    ax.set_xlim(-0.01, p.box_width + 0.01)
    ax.set_ylim(-0.01, p.box_height + 0.01)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
