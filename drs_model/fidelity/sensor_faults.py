"""Faults of the sensor that reports the actuator's state: a bias, noise with a seed, dropouts
and a frozen value, applied to what is published, never to the physics.

Each draw is a function of ``(seed, step)`` alone (``numpy.random.default_rng((seed, step))``),
so a re-run reproduces every noisy sample and every dropout whatever it sampled before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ParameterError
from ..params import real_number


@dataclass(frozen=True)
class SensorFaults:
    """What the stroke sensor does wrong: ``bias`` [m] added, Gaussian noise of standard
    deviation ``noise`` [m] drawn from ``seed``, a reading lost (NaN) with probability
    ``dropout`` per sample, and, from ``frozen_from`` [s] on, the last reading before it
    repeated (``inf``: never). The default is a healthy sensor."""

    bias: float = 0.0
    noise: float = 0.0
    seed: int = 0
    dropout: float = 0.0
    frozen_from: float = math.inf

    def __post_init__(self) -> None:
        for name in ("bias", "noise", "dropout"):
            object.__setattr__(self, name, real_number(name, getattr(self, name)))
        if self.noise < 0.0:
            raise ParameterError(f"noise must be >= 0 m, got {self.noise!r}")
        if not 0.0 <= self.dropout <= 1.0:
            raise ParameterError(f"dropout must be in [0, 1], got {self.dropout!r}")
        if (
            isinstance(self.seed, bool)
            or not isinstance(self.seed, (int, np.integer))
            or (self.seed < 0)
        ):
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        if math.isnan(self.frozen_from):
            raise ParameterError("frozen_from must be a time [s] or inf, got nan")


class StrokeSensor:
    """The stroke as a faulty sensor reports it, sample by sample (``read``)."""

    def __init__(self, faults: SensorFaults) -> None:
        self.faults = faults
        self._held: float | None = None

    def read(self, t: float, step: int, stroke: float) -> float:
        """The reading [m] at time ``t`` [s], physics step ``step``, of the true ``stroke``."""
        f = self.faults
        if t >= f.frozen_from and self._held is not None:
            return self._held
        value = stroke + f.bias
        if f.noise > 0.0 or f.dropout > 0.0:
            rng = np.random.default_rng((f.seed, step))
            if f.dropout > 0.0 and rng.random() < f.dropout:
                return math.nan
            if f.noise > 0.0:
                value += f.noise * rng.standard_normal()
        self._held = value  # the last reading; from frozen_from on it repeats
        return value

    def freeze(self, t: float, step: int, stroke: float) -> None:
        """From time ``t`` [s] (physics step ``step``) on, repeat the reading of the true
        ``stroke`` [m] there; a dropout there holds the biased stroke instead (a frozen sensor
        outputs a value)."""
        held = self.read(t, step, stroke)
        self._held = stroke + self.faults.bias if math.isnan(held) else held
        self.faults = replace(self.faults, frozen_from=t)

    def thaw(self) -> None:
        """The sensor reads the stroke again."""
        self.faults = replace(self.faults, frozen_from=math.inf)
