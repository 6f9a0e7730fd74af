"""The ladder measured: every rung on every standard scene, its error against the hydraulic
reference and its cost per simulated second, and the cheapest rung that meets a tolerance.

The reference is the hydraulic rung stepped with RK4 at a quarter of the largest stable
sub-step of every step (the tight run; the default, the whole stable sub-step, is within
2e-6 m and 10 N of RK4 at 2 us sub-steps on the open-hold-close scene). Errors are the
largest differences over the scene, sampled at every step: gap and stroke [m], piston force [N]
(none on the kinematic rung), and the opening and closing times [s] (from the command to 95 %
of the gap's travel, :func:`event_times`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..params import DRSParams
from .scenes import STANDARD_SCENES, Scene, Trace, run_scene

#: What the chart compares, and their units.
QUANTITIES = {"gap": "m", "stroke": "m", "force": "N", "opening": "s", "closing": "s"}
#: The default tolerances of :func:`needed_rung`: 0.5 mm, 0.5 mm, 100 N, 5 ms, 5 ms.
DEFAULT_TOLERANCES = {"gap": 5e-4, "stroke": 5e-4, "force": 100.0, "opening": 5e-3, "closing": 5e-3}
#: The runs of the chart: (label, rung, options).
RUNS = (
    ("kinematic (batch)", "kinematic", {"batch": True}),
    ("kinematic", "kinematic", {}),
    ("quasi-static", "quasi-static", {}),
    ("rigid", "rigid", {}),
    ("hydraulic", "hydraulic", {}),
)
REFERENCE = (
    "hydraulic (reference)",
    "hydraulic",
    {"method": "rk4", "stability_fraction": 1.0 / 16.0, "locate_events": True},
)


def _opens(action: str, argument) -> bool | None:
    """Whether a scene's command opens the flap (True), closes it (False), or neither."""
    if action == "force":
        return True
    if action == "lose_supply":
        return False
    if action == "drs":
        return bool(argument)
    if action == "move":
        return bool(argument[0])
    return None


def event_times(trace: Trace, scene: Scene, p: DRSParams) -> tuple[float, float]:
    """``(opening, closing)`` [s]: from the first command that opens (a ``drs`` or ``move`` to
    open, or a force) to the gap's first reaching 95 % of its travel, and from the first that
    closes (to closed, or a supply loss) to its first falling within 5 % of closed; NaN without
    such a command, inf if the gap never gets there."""
    span = p.gap_open - p.gap_closed
    out = []
    for opening in (True, False):
        starts = [t for t, action, arg in scene.events if _opens(action, arg) is opening]
        if not starts:
            out.append(math.nan)
            continue
        t0 = min(starts)
        after = trace.t > t0
        done = (
            trace.gap >= p.gap_closed + 0.95 * span
            if opening
            else trace.gap <= p.gap_closed + 0.05 * span
        )
        hits = np.flatnonzero(after & done)
        out.append(float(trace.t[hits[0]] - t0) if hits.size else math.inf)
    return out[0], out[1]


def _time_error(a: float, b: float) -> float:
    """``|a - b|`` [s], 0 where both never happen (inf), NaN where the scene has no command."""
    if math.isinf(a) and math.isinf(b):
        return 0.0
    return abs(a - b)


def errors(trace: Trace, reference: Trace, scene: Scene, p: DRSParams) -> dict[str, float]:
    """The largest differences of ``trace`` from ``reference`` (module docstring); NaN for what
    the rung does not model."""
    opening, closing = event_times(trace, scene, p)
    ref_open, ref_close = event_times(reference, scene, p)
    return {
        "gap": float(np.max(np.abs(trace.gap - reference.gap))),
        "stroke": float(np.max(np.abs(trace.stroke - reference.stroke))),
        "force": float(np.max(np.abs(trace.force - reference.force))),
        "opening": _time_error(opening, ref_open),
        "closing": _time_error(closing, ref_close),
    }


def chamber_floor(trace: Trace) -> dict[str, float] | None:
    """Each chamber's lowest pressure [Pa] and the time [s] it spends with a vapour cavity open
    (at the vapour pressure), counted in the trace's steps: ``{"lowest_pressure_a", ...,
    "time_at_floor_b"}``; None for a rung without chambers."""
    if trace.pressure_a.size == 0:
        return None
    dt = float(trace.t[1] - trace.t[0]) if trace.t.size > 1 else 0.0
    return {
        "lowest_pressure_a": float(np.min(trace.pressure_a)),
        "lowest_pressure_b": float(np.min(trace.pressure_b)),
        "time_at_floor_a": dt * int(np.count_nonzero(trace.cavity_a > 0.0)),
        "time_at_floor_b": dt * int(np.count_nonzero(trace.cavity_b > 0.0)),
    }


@dataclass
class LadderRow:
    """One run of one scene: the label, the rung, its errors (None if refused), its cost per
    simulated second [s/s], its event times [s], the reason of a refusal and, for a rung with
    chambers, :func:`chamber_floor`."""

    scene: str
    label: str
    rung: str
    errors: dict[str, float] | None
    cost_per_second: float
    opening: float
    closing: float
    refused: str | None = None
    chambers: dict[str, float] | None = None


def measure(
    p: DRSParams | None = None,
    dt: float = 1e-3,
    scenes=STANDARD_SCENES,
    lap_seconds: float | None = None,
    progress=None,
    hydraulic=None,
) -> list[LadderRow]:
    """Every run of :data:`RUNS` and the reference on every scene. ``lap_seconds`` shortens the
    gap stream's lap (its commands scaled with it; a quick look). ``progress(label)`` is called
    before each run. ``hydraulic`` (a :class:`~.hydraulic_params.HydraulicParams`) replaces the
    hydraulic rung's defaults, in its run and the reference's."""
    p = DRSParams() if p is None else p
    extra = {} if hydraulic is None else {"hydraulic": hydraulic}
    rows = []
    for scene in scenes:
        if lap_seconds is not None and scene.repeat > 1:
            k = lap_seconds / scene.duration
            scene = Scene(
                scene.name,
                lap_seconds,
                tuple((round(t * k, 3), a, x) for t, a, x in scene.events),
                scene.repeat,
                scene.description,
            )
        if progress:
            progress(f"{scene.name}: {REFERENCE[0]}")
        ref = run_scene(REFERENCE[1], scene, p, dt, **REFERENCE[2], **extra)
        ref_times = event_times(ref, scene, p)
        rows.append(
            LadderRow(
                scene.name,
                REFERENCE[0],
                REFERENCE[1],
                None,
                ref.cost_per_second,
                *ref_times,
                chambers=chamber_floor(ref),
            )
        )
        for label, rung, options in RUNS:
            if progress:
                progress(f"{scene.name}: {label}")
            tr = run_scene(rung, scene, p, dt, **options, **(extra if rung == "hydraulic" else {}))
            if tr.refused:
                rows.append(
                    LadderRow(
                        scene.name, label, rung, None, math.nan, math.nan, math.nan, tr.refused
                    )
                )
                continue
            rows.append(
                LadderRow(
                    scene.name,
                    label,
                    rung,
                    errors(tr, ref, scene, p),
                    tr.cost_per_second,
                    *event_times(tr, scene, p),
                    chambers=chamber_floor(tr),
                )
            )
    return rows


def needed_rung(rows: list[LadderRow], scene: str, quantities, tolerances=None) -> str | None:
    """The cheapest run of ``scene`` whose errors in ``quantities`` (keys of
    :data:`QUANTITIES`) are all within ``tolerances`` (default :data:`DEFAULT_TOLERANCES`); a
    quantity a rung does not model (NaN) fails it. None if no rung but the reference does."""
    tol = {**DEFAULT_TOLERANCES, **(tolerances or {})}
    fits = [
        r
        for r in rows
        if r.scene == scene
        and r.errors is not None
        and all(
            (not math.isnan(r.errors[q]) or _both_nan(rows, scene, r, q))
            and (math.isnan(r.errors[q]) or r.errors[q] <= tol[q])
            for q in quantities
        )
    ]
    if not fits:
        return None
    return min(fits, key=lambda r: r.cost_per_second).label


def _both_nan(rows, scene, row, quantity) -> bool:
    """A time the scene has no command for (NaN for every rung) is no failure."""
    if quantity not in ("opening", "closing"):
        return False
    ref = next(r for r in rows if r.scene == scene and r.errors is None and r.refused is None)
    return math.isnan(getattr(ref, quantity))
