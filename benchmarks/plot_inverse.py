"""Figures of docs/dynamics.md: the piston force of the three formulations (the seed's
"Overlapping" plot) and the force for the two flap inertias. Run:
``.venv/bin/python benchmarks/plot_inverse.py`` (writes docs/img/*.png).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from drs_model.inverse import manoeuvre_force, peak_force  # noqa: E402
from drs_model.params import SEED_LITERAL_IZ_WING, DRSParams  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "docs" / "img"
STYLES = {
    "newton-euler": dict(color="tab:green", lw=4.0, alpha=0.6),
    "lagrange": dict(color="tab:blue", lw=2.2, ls="--"),
    "virtual-work": dict(color="tab:orange", lw=1.2, ls=":"),
}


def plot_methods(p: DRSParams, path: Path) -> None:
    t = np.linspace(0.0, p.T_total, 5001)
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=120)
    for m, style in STYLES.items():
        ax.plot(t * 1e3, manoeuvre_force(t, p, m) / 1e3, label=m, **style)
    pk = peak_force(p)
    ax.plot(pk.time * 1e3, pk.force / 1e3, "kv", ms=8)
    ax.annotate(
        f"peak {pk.force / 1e3:.2f} kN\nt = {pk.time * 1e3:.3f} ms, s = {pk.stroke * 1e3:.3f} mm",
        (pk.time * 1e3, pk.force / 1e3),
        xytext=(8, -34),
        textcoords="offset points",
    )
    ax.set(
        xlabel="time t [ms]",
        ylabel="piston force F [kN]",
        title=f"Piston force, three formulations overlapping (Iz_wing = {p.Iz_wing:.4g} kg m^2)",
    )
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_inertias(path: Path) -> None:
    t = np.linspace(0.0, DRSParams().T_total, 5001)
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=120)
    cases = [
        (DRSParams(), "Iz_wing = m L^2 / 3 = 0.0096 kg m^2 (default)", "tab:blue"),
        (
            DRSParams(Iz_wing=SEED_LITERAL_IZ_WING),
            "Iz_wing = m L / 3 = 0.08 (seed's literal)",
            "tab:red",
        ),
    ]
    for p, label, color in cases:
        ax.plot(t * 1e3, manoeuvre_force(t, p) / 1e3, color=color, label=label)
        pk = peak_force(p)
        ax.plot(pk.time * 1e3, pk.force / 1e3, "v", color=color, ms=8)
        ax.annotate(
            f"{pk.force / 1e3:.1f} kN",
            (pk.time * 1e3, pk.force / 1e3),
            xytext=(8, 0),
            textcoords="offset points",
            color=color,
        )
    ax.set(
        xlabel="time t [ms]",
        ylabel="piston force F [kN]",
        title="Piston force for the two flap inertias (virtual work)",
    )
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    plot_methods(DRSParams(), OUT / "piston_force.png")
    plot_inertias(OUT / "piston_force_inertia.png")
    print(f"wrote {OUT / 'piston_force.png'} and {OUT / 'piston_force_inertia.png'}")


if __name__ == "__main__":
    main()
