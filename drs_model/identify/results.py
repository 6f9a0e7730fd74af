"""What a fit gives: each parameter's estimate with its interval (or the reason there is none),
the signals as measured and as fitted, the identifiability found, per stage and in all."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .identifiability import Identifiability


@dataclass(frozen=True)
class Estimate:
    """One parameter's result.

    Attributes
    ----------
    name, unit : str
    value : float
        The estimate; NaN where the data do not determine it (``reason`` says why).
    lower, upper : float
        The interval at the fit's level (NaN where none).
    std : float
        Standard error from the Jacobian.
    start : float
        The value the fit started from (the run's recorded or default value).
    stage : str
        ``"equation"`` or ``"output"`` (error).
    interval : str
        ``"jacobian"``, ``"log"`` (the Jacobian's on a log scale, for a positive parameter
        whose linear interval would cross its bound) or ``"profile"`` (``""`` with no value).
    reason : str
        Why no value: what the data cannot separate, and the motion that would determine it.
    guess : float
        The number the stage computed, reported or not (a withheld one is still the best start
        for the next stage; never a result).
    """

    name: str
    unit: str
    value: float
    lower: float
    upper: float
    std: float
    start: float
    stage: str
    interval: str = "jacobian"
    reason: str = ""
    guess: float = math.nan

    @classmethod
    def withheld(
        cls,
        name: str,
        unit: str,
        start: float,
        stage: str,
        reason: str,
        std: float = math.nan,
        guess: float = math.nan,
    ) -> Estimate:
        """A parameter given no value, no interval, and the ``reason`` (the standard error and
        the number the stage computed kept where there are some)."""
        nan = math.nan
        return cls(name, unit, nan, nan, nan, std, start, stage, "", reason, guess)

    @property
    def determined(self) -> bool:
        return not math.isnan(self.value)

    def contains(self, truth: float) -> bool:
        """Whether ``truth`` lies within the interval."""
        return self.determined and self.lower <= truth <= self.upper

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "unit": self.unit,
            "value": self.value,
            "lower": self.lower,
            "upper": self.upper,
            "std": self.std,
            "start": self.start,
            "stage": self.stage,
            "interval": self.interval,
            "determined": self.determined,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class FittedSignal:
    """A signal as measured and as the fitted model gives it, at the times ``t`` [s]."""

    name: str
    unit: str
    t: np.ndarray
    measured: np.ndarray
    fitted: np.ndarray

    @property
    def residual_rms(self) -> float:
        r = self.measured - self.fitted
        r = r[np.isfinite(r)]
        return float(np.sqrt(np.mean(r * r))) if r.size else math.nan

    def summary(self) -> dict:
        r = self.measured - self.fitted
        r = r[np.isfinite(r)]
        return {
            "signal": self.name,
            "unit": self.unit,
            "samples": int(r.size),
            "residual_rms": self.residual_rms,
            "residual_max": float(np.max(np.abs(r))) if r.size else math.nan,
        }


@dataclass(frozen=True)
class StageFit:
    """One stage's fit of some of the parameters (one regression, or the output error)."""

    stage: str
    label: str
    estimates: tuple[Estimate, ...]
    identifiability: Identifiability
    signals: tuple[FittedSignal, ...] = ()
    sigma2: float = math.nan
    dof: int = 0
    seconds: float = math.nan
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class FitResult:
    """A whole fit: the final estimate of each parameter asked for (the output error's where it
    ran and determined it, else the equation error's), every stage, and the parameters on which
    the stages disagree by more than their intervals allow (``inconsistent``)."""

    rung: str
    level: float
    estimates: tuple[Estimate, ...]
    stages: tuple[StageFit, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)
    inconsistent: tuple[str, ...] = ()

    def estimate(self, name: str) -> Estimate:
        for e in self.estimates:
            if e.name == name:
                return e
        raise KeyError(name)

    @property
    def signals(self) -> tuple[FittedSignal, ...]:
        """The signals of the last stage that has any (the output error's, where it ran)."""
        for stage in reversed(self.stages):
            if stage.signals:
                return stage.signals
        return ()

    def to_dict(self) -> dict:
        return {
            "rung": self.rung,
            "level": self.level,
            "estimates": [e.to_dict() for e in self.estimates],
            "stages": [
                {
                    "stage": s.stage,
                    "label": s.label,
                    "seconds": s.seconds,
                    "sigma2": s.sigma2,
                    "dof": s.dof,
                    "identifiability": s.identifiability.to_dict(),
                    "estimates": [e.to_dict() for e in s.estimates],
                    "residuals": [sig.summary() for sig in s.signals],
                    "notes": list(s.notes),
                }
                for s in self.stages
            ],
            "notes": list(self.notes),
            "inconsistent": list(self.inconsistent),
        }


__all__ = ["Estimate", "FitResult", "FittedSignal", "StageFit"]
