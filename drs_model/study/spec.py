"""A study's specification: which DRSParams fields vary and how, the sampler, and the scene.

Read from TOML (``drs study SPEC.toml``, an example in ``config/study.toml``)::

    [sampler]
    method = "lhs"         # "lhs" (Latin hypercube) or "sobol" (scrambled Sobol'), scipy.stats.qmc
    samples = 256          # base samples n
    seed = 19
    sensitivity = true     # Sobol' indices: n * (d + 2) runs (the pick-freeze design)

    [scene]
    opening_force = 3000.0 # [N] constant, from rest at the closed stop: the opening time
    closing_force = 0.0    # [N] constant, from rest at the open stop: the closing time
    horizon = 0.2          # [s] longest forward run
    grid = 5001            # times along the manoeuvre before the refinement (as `drs peak`)
    rtol = 1e-10           # forward dynamics' relative tolerance

    [design]               # optional: DRSParams overrides of the nominal design
    Iz_wing = 0.0024

    [parameters.L2]        # one table per varied field
    distribution = "normal"
    mean = 0.050           # [m] (default: the design's value)
    std = 5e-5

    [parameters.m_wing]
    distribution = "uniform"
    low = 1.9
    high = 2.1

Every error is a :class:`~drs_model.errors.StudySpecError` naming the bad table, key or value and
the valid ones.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from ..errors import StudySpecError
from ..params import NUMERIC_FIELDS, DRSParams, from_dict

SAMPLERS = ("lhs", "sobol")


def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise StudySpecError(f"{where} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise StudySpecError(f"{where} must be finite, got {value!r}")
    return value


def _integer(where: str, value: Any, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise StudySpecError(f"{where} must be a whole number >= {least}, got {value!r}")
    return value


def _keys(where: str, table: Any, valid: tuple[str, ...], required: tuple[str, ...] = ()):
    if not isinstance(table, Mapping):
        raise StudySpecError(f"{where} must be a table, got {table!r}")
    unknown = sorted(set(table) - set(valid))
    if unknown:
        raise StudySpecError(f"{where}: unknown key(s) {unknown}; valid keys: {list(valid)}")
    missing = [k for k in required if k not in table]
    if missing:
        raise StudySpecError(f"{where}: missing key(s) {missing}")
    return table


@dataclass(frozen=True)
class Uniform:
    """Uniform on ``[low, high]`` (the field's unit)."""

    low: float
    high: float

    def __post_init__(self) -> None:
        if not self.low < self.high:
            raise StudySpecError(
                f"uniform needs low < high, got low={self.low!r}, high={self.high!r}"
            )

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """The values at the quantiles ``u`` in [0, 1)."""
        return self.low + u * (self.high - self.low)


@dataclass(frozen=True)
class Normal:
    """Normal of ``mean`` and standard deviation ``std`` (the field's unit)."""

    mean: float
    std: float

    def __post_init__(self) -> None:
        if not self.std > 0.0:
            raise StudySpecError(f"normal needs std > 0, got std={self.std!r}")

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """The values at the quantiles ``u`` in (0, 1) (scipy.stats.norm)."""
        return stats.norm.ppf(u, loc=self.mean, scale=self.std)


#: Distribution name -> (its keys, the required ones).
DISTRIBUTIONS = {
    "uniform": (("distribution", "low", "high"), ("low", "high")),
    "normal": (("distribution", "mean", "std"), ("std",)),
}


@dataclass(frozen=True)
class Scene:
    """What each sample is asked: the forces [N] of the opening and closing runs, the longest run
    [s], the manoeuvre's grid before the refinement, the forward runs' relative tolerance."""

    opening_force: float = 3000.0
    closing_force: float = 0.0
    horizon: float = 0.2
    grid: int = 5001
    rtol: float = 1e-10

    def __post_init__(self) -> None:
        for name in ("opening_force", "closing_force", "horizon", "rtol"):
            object.__setattr__(self, name, _number(f"[scene] {name}", getattr(self, name)))
        _integer("[scene] grid", self.grid, 3)
        if not self.horizon > 0.0:
            raise StudySpecError(f"[scene] horizon must be > 0 s, got {self.horizon!r}")
        if not 0.0 < self.rtol < 1.0:
            raise StudySpecError(f"[scene] rtol must lie in (0, 1), got {self.rtol!r}")


@dataclass(frozen=True)
class StudySpec:
    """A parsed, validated study: the design, the varied fields and their distributions (in the
    spec's order), the sampler and the scene."""

    design: DRSParams
    fields: tuple[str, ...]
    distributions: tuple[Uniform | Normal, ...]
    sampler: str = "lhs"
    samples: int = 256
    seed: int = 0
    sensitivity: bool = True
    scene: Scene = field(default_factory=Scene)

    def __post_init__(self) -> None:
        if self.sampler not in SAMPLERS:
            raise StudySpecError(
                f"[sampler] method must be one of {list(SAMPLERS)}, got {self.sampler!r}"
            )
        if not self.fields:
            raise StudySpecError("a study varies at least one parameter: add a [parameters.NAME]")

    @property
    def runs(self) -> int:
        """Samples evaluated: ``n (d + 2)`` with the sensitivity design, else ``n``."""
        return self.samples * (len(self.fields) + 2) if self.sensitivity else self.samples


def parse_spec(data: Mapping[str, Any]) -> StudySpec:
    """A :class:`StudySpec` from the tables of a TOML document."""
    _keys("the spec", data, ("sampler", "scene", "design", "parameters"), ("parameters",))
    sampler = _keys(
        "[sampler]", data.get("sampler", {}), ("method", "samples", "seed", "sensitivity")
    )
    scene_table = _keys("[scene]", data.get("scene", {}), tuple(Scene.__dataclass_fields__))
    design = from_dict(_keys("[design]", data.get("design", {}), NUMERIC_FIELDS))
    scene = Scene(**scene_table)  # validated by Scene itself
    params = data["parameters"]
    if not isinstance(params, Mapping):
        raise StudySpecError(f"[parameters] must hold one table per field, got {params!r}")
    fields, dists = [], []
    for name, table in params.items():
        where = f"[parameters.{name}]"
        if name not in NUMERIC_FIELDS:
            raise StudySpecError(
                f"{where}: {name!r} is not a DRSParams field; valid fields: {list(NUMERIC_FIELDS)}"
            )
        if not isinstance(table, Mapping) or "distribution" not in table:
            raise StudySpecError(
                f"{where} needs distribution = one of {list(DISTRIBUTIONS)}, got {table!r}"
            )
        kind = table["distribution"]
        if kind not in DISTRIBUTIONS:
            raise StudySpecError(
                f"{where}: unknown distribution {kind!r}; valid distributions: "
                f"{list(DISTRIBUTIONS)}"
            )
        valid, required = DISTRIBUTIONS[kind]
        _keys(f"{where} ({kind})", table, valid, required)
        try:
            if kind == "uniform":
                dist = Uniform(
                    _number(f"{where} low", table["low"]), _number(f"{where} high", table["high"])
                )
            else:
                mean = table.get("mean", getattr(design, name))
                dist = Normal(_number(f"{where} mean", mean), _number(f"{where} std", table["std"]))
        except StudySpecError as exc:
            if str(exc).startswith(where):
                raise
            raise StudySpecError(f"{where}: {exc}") from None
        fields.append(name)
        dists.append(dist)
    return StudySpec(
        design=design,
        fields=tuple(fields),
        distributions=tuple(dists),
        sampler=sampler.get("method", "lhs"),
        samples=_integer("[sampler] samples", sampler.get("samples", 256), 2),
        seed=_integer("[sampler] seed", sampler.get("seed", 0), 0),
        sensitivity=_flag("[sampler] sensitivity", sampler.get("sensitivity", True)),
        scene=scene,
    )


def _flag(where: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise StudySpecError(f"{where} must be true or false, got {value!r}")
    return value


def read_spec(path: str | Path) -> StudySpec:
    """The :class:`StudySpec` of a TOML file."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise StudySpecError(f"cannot read study spec {str(path)!r}: {exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise StudySpecError(f"study spec {str(path)!r} is not valid TOML: {exc}") from exc
    return parse_spec(data)
