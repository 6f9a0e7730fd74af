"""Figures of the mechanism and of the Coriolis examples (matplotlib, imported lazily so the model
does not need it)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import kinematics as kin
from .coriolis import SEED_COLLAR, SEED_SLOTTED_LINK, CollarExample, SlottedLinkExample
from .errors import InputError
from .params import DRSParams


# ---- one matplotlib set-up: Agg figures without pyplot, saved as 256-colour PNGs -------------
def _out_dir(out_dir) -> Path:
    path = Path(out_dir)
    if path.exists() and not path.is_dir():
        raise InputError(f"plot directory {str(path)!r} exists and is not a directory")
    path.mkdir(parents=True, exist_ok=True)
    return path


def _figure(figsize: tuple[float, float], dpi: int):
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ModuleNotFoundError as exc:  # pragma: no cover - matplotlib is an optional extra
        raise ModuleNotFoundError(
            "plots need matplotlib: pip install 'drs[plots]'", name=exc.name
        ) from exc
    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)  # Agg without pyplot: no global backend state
    return fig


def _save(fig, path: Path) -> None:
    """Write ``fig`` as a 256-colour PNG (a third of the size of a true-colour one)."""
    from PIL import Image  # a dependency of matplotlib

    fig.canvas.draw()
    rgb = Image.fromarray(np.asarray(fig.canvas.buffer_rgba())).convert("RGB")
    rgb.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


# ---- the mechanism -----------------------------------------------------------------------------
def mechanism_figure(p: DRSParams, strokes, path: str | Path, title: str | None = None) -> Path:
    """Draw the mechanism at the given strokes [m] (one colour each) and save a PNG at ``path``.

    Shows the FIA box, the pylon, the main wing, the piston A-B, the link B-C, the flap outline,
    the gap T-R, the workspace traces of B and C and the fixed points A, D.
    """
    strokes = np.atleast_1d(np.asarray(strokes, dtype=float))
    q = kin.solve_position(strokes, p)
    fig = _figure((8.0, 5.5), 110)
    from matplotlib import colormaps
    from matplotlib.patches import Rectangle

    ax = fig.add_subplot()
    ax.add_patch(
        Rectangle(
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
    colors = colormaps["viridis"](np.linspace(0.0, 0.85, len(strokes)))
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
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _save(fig, path)
    return path


# ---- Coriolis examples (seed 000) -------------------------------------------------------------
def _collar_map(
    example: CollarExample, surface, sym: str, unit: str, value: float, rates: str, dpi: int
):
    """One quantity's figure: its contour over ``surface = (r, theta [deg], z)`` with the
    example-1 point marked (value ``value``), and its surface."""
    r_map, th_map, z = surface
    unit_tex = unit.replace("^2", "$^2$")
    label = rf"${sym}$ [{unit_tex}]"
    fig = _figure((11.0, 4.6), dpi)
    ax = fig.add_subplot(1, 2, 1)
    cs = ax.contour(r_map, th_map, z, levels=14, cmap="viridis")
    ax.clabel(cs, fontsize=7, fmt="%.3g")
    ax.plot(
        example.r,
        math.degrees(example.theta),
        "o",
        color="tab:red",
        ms=8,
        label=(
            f"example 1: r = {example.r:g} m, θ = {math.degrees(example.theta):g}°, "
            rf"${sym}$ = {value:.4g} {unit_tex}"
        ),
    )
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.12), fontsize=8, frameon=False)
    ax.set_xlabel("distance A-B, r [m]")
    ax.set_ylabel("rod angle θ [deg]")
    ax.set_title(f"{label}: contour")
    ax.grid(True, alpha=0.3)
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    ax3.plot_surface(r_map, th_map, z, cmap="viridis", linewidth=0, antialiased=False)
    ax3.scatter(
        [example.r],
        [math.degrees(example.theta)],
        [value],
        color="tab:red",
        s=30,
        depthshade=False,
    )
    ax3.set_xlabel("r [m]")
    ax3.set_ylabel("θ [deg]")
    ax3.set_zlabel(label)
    ax3.set_title(f"{label}: surface")
    fig.suptitle(f"Collar B on a rotating rod, fixed-frame ${sym}$ ({rates})", fontsize=10)
    return fig


def plot_collar_maps(
    out_dir,
    example: CollarExample = SEED_COLLAR,
    *,
    n_theta: int = 91,
    n_r: int = 41,
    dpi: int = 100,
) -> list[Path]:
    """Example 2: contour + surface maps of v_X, v_Y, a_X, a_Y over rod angle and distance.

    Writes ``collar_vx.png``, ``collar_vy.png``, ``collar_ax.png``, ``collar_ay.png`` into
    ``out_dir`` (created if missing); each contour marks the example-1 point.

    Parameters
    ----------
    out_dir : str or Path
        Output directory.
    example : CollarExample
        Rod and collar rates, marker point and map ranges (default: the seed's).
    n_theta, n_r : int
        Grid points along the angle and the distance.
    dpi : int
        Resolution of the PNGs.

    Returns
    -------
    list of Path
        The files written.
    """
    out = _out_dir(out_dir)
    grid = example.grid(n_theta, n_r)
    point = example.kinematics()
    r_map = grid.motion.r
    th_map = np.degrees(grid.motion.theta)
    quantities = (
        ("vx", "v_X", "m/s", grid.fixed.velocity.total[..., 0], point.fixed.velocity.total[0]),
        ("vy", "v_Y", "m/s", grid.fixed.velocity.total[..., 1], point.fixed.velocity.total[1]),
        (
            "ax",
            "a_X",
            "m/s^2",
            grid.fixed.acceleration.total[..., 0],
            point.fixed.acceleration.total[0],
        ),
        (
            "ay",
            "a_Y",
            "m/s^2",
            grid.fixed.acceleration.total[..., 1],
            point.fixed.acceleration.total[1],
        ),
    )
    rates = (
        rf"$\omega$ = {example.omega:g} rad/s, $\alpha$ = {example.alpha:g} rad/s$^2$, "
        rf"$\dot r$ = {example.r_dot:g} m/s, $\ddot r$ = {example.r_ddot:g} m/s$^2$"
    )
    written = []
    for key, sym, unit, z, value in quantities:
        fig = _collar_map(example, (r_map, th_map, z), sym, unit, float(value), rates, dpi)
        path = out / f"collar_{key}.png"
        _save(fig, path)
        written.append(path)
    return written


def plot_slotted_link(
    out_dir, link: SlottedLinkExample = SEED_SLOTTED_LINK, *, n: int = 361, dpi: int = 100
) -> list[Path]:
    """Example 3: rod angular velocity/acceleration and stroke velocity/acceleration vs theta.

    Writes ``slotted_link.png`` (closed form as lines, the closure solution every 15 deg as dots)
    into ``out_dir`` (created if missing). SI units, CCW positive. Returns the files written.
    """
    out = _out_dir(out_dir)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InputError(f"n must be an integer >= 2, got {n!r}")
    theta = np.linspace(0.0, 2.0 * math.pi, n)
    theta_dots = np.radians(np.arange(0.0, 360.0 + 1e-9, 15.0))
    curve = link.solve(theta, "closed-form")
    dots = link.solve(theta_dots, "closure")
    panels = (
        ("omega_rod", r"rod angular velocity $\omega_{rod}$ [rad/s]"),
        ("stroke_velocity", r"stroke velocity $\dot L$ [m/s]"),
        ("alpha_rod", r"rod angular acceleration $\alpha_{rod}$ [rad/s$^2$]"),
        ("stroke_acceleration", r"stroke acceleration $\ddot L$ [m/s$^2$]"),
    )
    fig = _figure((10.0, 7.0), dpi)
    axes = fig.subplots(2, 2, sharex=True)
    for ax, (field, label) in zip(axes.ravel(), panels, strict=True):
        ax.plot(np.degrees(theta), getattr(curve, field), color="tab:blue", label="closed form")
        ax.plot(
            np.degrees(theta_dots),
            getattr(dots, field),
            "o",
            ms=4,
            color="tab:orange",
            label="closure at C (2x2 solve)",
        )
        ax.set_ylabel(label)
        ax.set_title(label.split(" [")[0].split(" $")[0] + " vs wheel angle", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.set_xticks(np.arange(0, 361, 60))
    for ax in axes[1]:
        ax.set_xlabel("wheel angle θ [deg]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(
        f"Slotted link: r = {link.r * 1e3:g} mm, d = {link.d * 1e3:g} mm, "
        rf"$\omega$ = {link.omega:g} rad/s, $\alpha$ = {link.alpha:g} rad/s$^2$ "
        "(rates CCW positive; L = |CB|)",
        fontsize=10,
    )
    path = out / "slotted_link.png"
    _save(fig, path)
    return [path]


# ---- the fidelity ladder ----------------------------------------------------------------------
def plot_fidelity(rows, path, dpi: int = 100) -> Path:
    """The fidelity chart: per scene, each rung's largest gap error against the hydraulic
    reference [m] over its cost per simulated second [s/s] (log-log; an exact zero drawn at the
    floor), as a PNG at ``path``."""
    path = Path(path)
    _out_dir(path.parent)
    scenes = list(dict.fromkeys(r.scene for r in rows))
    cols = min(3, len(scenes))
    rows_n = math.ceil(len(scenes) / cols)
    fig = _figure((4.2 * cols, 3.4 * rows_n), dpi)
    grid = fig.subplots(rows_n, cols, squeeze=False).ravel()
    for ax in grid[len(scenes) :]:
        ax.set_visible(False)
    axes = grid[: len(scenes)]
    floor = 1e-9
    markers = {"kinematic": "o", "quasi-static": "s", "rigid": "D", "hydraulic": "^"}
    labels = list(dict.fromkeys(r.label for r in rows if r.errors is not None))
    colours = {label: f"C{i}" for i, label in enumerate(labels)}  # one colour per run
    for ax, scene in zip(axes, scenes, strict=True):
        for r in rows:
            if r.scene != scene or r.errors is None or not math.isfinite(r.cost_per_second):
                continue
            err = max(r.errors["gap"], floor)
            ax.loglog(
                r.cost_per_second,
                err,
                markers.get(r.rung, "x"),
                color=colours[r.label],
                label=r.label,
                alpha=0.8,
            )
        ref = next(
            (r for r in rows if r.scene == scene and r.errors is None and not r.refused), None
        )
        if ref is not None:
            ax.axvline(ref.cost_per_second, color="grey", lw=0.8, ls="--")
        ax.set_title(scene, fontsize=9)
        ax.set_xlabel("cost per simulated second [s/s]", fontsize=8)
        ax.set_ylabel("max gap error vs hydraulic [m]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", lw=0.3)
    handles, names = [], []
    for ax in axes:
        for h, n in zip(*ax.get_legend_handles_labels(), strict=True):
            if n not in names:
                handles.append(h)
                names.append(n)
    fig.legend(
        handles,
        names,
        loc="lower right",
        fontsize=8,
        title="dashed: the reference's cost",
        title_fontsize=7,
    )
    _save(fig, path)
    return path
