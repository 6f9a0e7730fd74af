"""What a run measured, as arrays: the input of every fit.

A :class:`Record` holds one run's samples by signal, each an array of the same length as the
sample times, NaN where a sample was lost (a dropout); a signal the run did not record is
``None``. Where they come from (a bag, a table, a simulation) is not its business: the bag tools
fill it (:mod:`drs_ros.bag.season.measured`), the tests from the rungs directly.

Signals (SI units):

``stroke`` [m]
    the stroke sensor's reading (the piston's ``position``);
``stroke_rate`` [m/s], ``stroke_acceleration`` [m/s^2]
    recorded rates, or, where a run has none, derivatives of the stroke (:meth:`Record.rates`);
``piston_force`` [N]
    the force the rod gives the mechanism (the piston's ``effort``: after friction, as a load
    cell between rod and link measures it);
``pressure_a``, ``pressure_b``, ``supply_pressure`` [Pa]
    the piston-side and rod-side chambers, the supply;
``spool`` [1]
    the valve spool, normalised to -1..1.

``stops_hold`` says whether an end stop may have held the rod against the piston's force (a
force command, or a run whose commands are unknown: the default); a run under stroke commands
only is moved by its piston to and from the stops, so its force there is the model's.

``step`` is each sample's physics step in the recorded run (for a re-simulation to compare the
same instants); ``None`` where the run says nothing of its steps.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

from ..errors import InputError

#: The signals a record may hold, with their units.
SIGNALS = {
    "stroke": "m",
    "stroke_rate": "m/s",
    "stroke_acceleration": "m/s^2",
    "piston_force": "N",
    "pressure_a": "Pa",
    "pressure_b": "Pa",
    "supply_pressure": "Pa",
    "spool": "1",
}

#: Samples measured within this distance [m] of a stop are taken as on it, where a regression
#: reads a force the stop's is not in (the rigid regression on the hydraulic rung or where a
#: stop may have held the rod, the rod balance on the mechanism's need): a rod on a compliant
#: stop sits micrometres past it, and the stroke sensor's noise moves it about.
STOP_BAND = 1e-4
#: Savitzky-Golay window [samples] of the derivatives of a stroke with no recorded rates.
DERIVATIVE_WINDOW = 7
#: Savitzky-Golay window [samples] of the septic that checks the quintic's derivatives.
CHECK_WINDOW = DERIVATIVE_WINDOW + 2
#: How many robust scales of a derived acceleration's stated error mark a kink in its window.
KINK_SCALES = 5.0


@dataclass(frozen=True)
class Record:
    """One run's samples (module docstring). Arrays are float64, one value per time."""

    t: np.ndarray
    stroke: np.ndarray
    stroke_rate: np.ndarray | None = None
    stroke_acceleration: np.ndarray | None = None
    piston_force: np.ndarray | None = None
    pressure_a: np.ndarray | None = None
    pressure_b: np.ndarray | None = None
    supply_pressure: np.ndarray | None = None
    spool: np.ndarray | None = None
    step: np.ndarray | None = None
    stops_hold: bool = True

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size < 3:
            raise InputError(f"a record needs at least 3 sample times, got shape {t.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0.0)):
            raise InputError("sample times must be finite and strictly increasing")
        object.__setattr__(self, "t", t)
        for name in SIGNALS:
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.asarray(value, dtype=float)
            if arr.shape != t.shape:
                raise InputError(f"{name} has {arr.shape} samples, the times {t.shape}")
            object.__setattr__(self, name, arr)
        if self.step is not None:
            step = np.asarray(self.step, dtype=np.int64)
            if step.shape != t.shape:
                raise InputError(f"step has {step.shape} entries, the times {t.shape}")
            object.__setattr__(self, "step", step)

    def __len__(self) -> int:
        return int(self.t.size)

    def has(self, *names: str) -> bool:
        """Whether every signal of ``names`` was recorded."""
        return all(getattr(self, n) is not None for n in names)

    def signals(self) -> tuple[str, ...]:
        """The signals recorded."""
        return tuple(n for n in SIGNALS if getattr(self, n) is not None)

    def rates(
        self, order: int = 3, window: int = DERIVATIVE_WINDOW
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(s', s'')`` [m/s, m/s^2]: as recorded, else Savitzky-Golay derivatives of the
        stroke of the polynomial ``order`` (cubic by default; at most the window's less one)
        over ``window`` samples (:data:`DERIVATIVE_WINDOW`; uniform sampling assumed)."""
        sd, sdd = self.stroke_rate, self.stroke_acceleration
        if sd is not None and sdd is not None:
            return sd, sdd
        dt = float(np.median(np.diff(self.t)))
        window = min(window, len(self) - (1 - len(self) % 2))
        order = min(order, window - 1)
        if sd is None:
            sd = savgol_filter(self.stroke, window, order, deriv=1, delta=dt)
        if sdd is None:
            sdd = savgol_filter(sd, window, order, deriv=1, delta=dt)
        return sd, sdd

    def derived(self, order: int = 3) -> dict[str, str]:
        """``{signal: how}`` for each rate :meth:`rates` (of that ``order``) derives instead of
        reading."""
        degree = {3: "cubic", 5: "quintic"}.get(order, f"degree {order}")
        how = f"Savitzky-Golay derivative ({degree}, {DERIVATIVE_WINDOW} samples) of the stroke"
        out = {}
        if self.stroke_rate is None:
            out["stroke_rate"] = how
        if self.stroke_acceleration is None:
            out["stroke_acceleration"] = how.replace("of the stroke", "of the stroke rate")
        return out

    def derivative_reach(self) -> int:
        """Samples on each side whose stroke a derived rate at a sample depends on (0 where
        both rates were recorded): half a window per differentiation."""
        if self.stroke_acceleration is not None:
            return 0 if self.stroke_rate is not None else DERIVATIVE_WINDOW // 2
        return DERIVATIVE_WINDOW // 2 * (2 if self.stroke_rate is None else 1)

    def stroke_noise(self) -> float:
        """The stroke sensor's noise [m] as the record shows it: the robust scatter (1.4826
        MAD) of the stroke about its local cubic (Savitzky-Golay, :data:`DERIVATIVE_WINDOW`
        samples), corrected for the smoother's own share of it, and never below the recorded
        values' resolution (a float64's spacing over sqrt 12: what a noise-free record has)."""
        s = self.stroke[np.isfinite(self.stroke)]
        resolution = float(np.sqrt(np.mean(np.spacing(np.abs(s)) ** 2) / 12.0))
        if s.size <= DERIVATIVE_WINDOW:
            return resolution
        scatter = s - savgol_filter(s, DERIVATIVE_WINDOW, 3)
        centre = float(savgol_coeffs(DERIVATIVE_WINDOW, 3)[DERIVATIVE_WINDOW // 2])
        mad = float(np.median(np.abs(scatter - np.median(scatter))))
        return max(1.4826 * mad / np.sqrt(1.0 - centre), resolution)

    def derivative_error(self) -> np.ndarray:
        """Per sample, a derived acceleration's error [m/s^2], signed: its difference from the
        same derivatives over the same window by a quintic (one that reaches no farther, so a
        stop's kink outside it shows in neither; truncation and noise both show in it); zeros
        where the acceleration was recorded."""
        if self.stroke_acceleration is not None:
            return np.zeros_like(self.t)
        return self.rates()[1] - self.rates(5)[1]

    def acceleration_error(self) -> np.ndarray:
        """Per sample, the quintic's derived acceleration's own error [m/s^2], signed: its
        difference from a septic's over :data:`CHECK_WINDOW` samples (the next order that
        truncates less; its window reaches one sample farther on each side, so next to a
        stop's kink it overstates the error, never hides it); zeros where the acceleration was
        recorded. On a smooth motion it is the quintic's true error within 1 %, where
        :meth:`derivative_error`, the quintic's correction of the cubic, is thousands of times
        it: what the quintic leaves, not what it corrected, biases a fit on it."""
        if self.stroke_acceleration is not None:
            return np.zeros_like(self.t)
        return self.rates(5)[1] - self.rates(7, CHECK_WINDOW)[1]

    def derivative_exclusions(self, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(window, kink)``, boolean per sample, for a regression of the samples ``ok`` on
        derived rates (none where both rates were recorded):

        * ``window``: the samples whose derivative window (:meth:`derivative_reach`) reaches a
          sample outside ``ok`` or the record's ends;
        * ``kink``: of the rest, those whose window holds a kink of the motion no local
          polynomial follows (a stop's impact, a trajectory's segment switch): within the reach
          of a sample whose :meth:`derivative_error` stands out of its own robust scale over
          those samples by more than :data:`KINK_SCALES` (and out of the arithmetic's share of
          the acceleration). There the stated error is 0.4 to 0.5 of the true one (the rigid
          rung's trajectory and stroke runs), so no weight pays for it."""
        reach = self.derivative_reach()
        none = np.zeros(len(self), dtype=bool)
        if not reach:
            return none, none
        kernel = np.ones(2 * reach + 1)
        window = np.convolve((~ok).astype(float), kernel, mode="same") > 0.0
        window[:reach], window[-reach:] = True, True
        rest = ok & ~window
        error = np.abs(self.derivative_error())
        if not np.any(error[rest]):
            return window & ok, none
        scale = 1.4826 * float(np.median(error[rest]))
        floor = 1e-9 * float(np.sqrt(np.mean(self.rates(5)[1][rest] ** 2)))
        flagged = (error > max(KINK_SCALES * scale, floor)) & rest
        kink = np.convolve(flagged.astype(float), kernel, mode="same") > 0.0
        return window & ok, kink & rest

    def select(self, mask: np.ndarray) -> Record:
        """The samples where ``mask`` is true."""
        mask = np.asarray(mask, dtype=bool)
        out = {"stops_hold": self.stops_hold}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name != "stops_hold":
                out[f.name] = None if value is None else value[mask]
        return Record(**out)


__all__ = ["CHECK_WINDOW", "DERIVATIVE_WINDOW", "KINK_SCALES", "SIGNALS", "STOP_BAND", "Record"]
