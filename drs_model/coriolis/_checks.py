"""Argument checks and array helpers shared by the Coriolis examples."""

from __future__ import annotations

import numpy as np

from ..errors import DegenerateGeometryError, InputError


def _finite(name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a real number or array, got {value!r}") from None
    if not np.all(np.isfinite(arr)):
        bad = float(arr[~np.isfinite(arr)].ravel()[0])
        raise InputError(f"{name} must be finite (-inf < {name} < inf), got {bad!r}")
    return arr


def _broadcast(**arrays: np.ndarray) -> list[np.ndarray]:
    try:
        return [np.array(a) for a in np.broadcast_arrays(*arrays.values())]
    except ValueError:
        shapes = ", ".join(f"{k} {np.shape(v)}" for k, v in arrays.items())
        raise InputError(f"arguments must broadcast to one shape, got {shapes}") from None


def _vector(name: str, value) -> np.ndarray:
    arr = _finite(name, value)
    if arr.ndim == 0 or arr.shape[-1] != 2:
        raise InputError(
            f"{name} must have shape (..., 2) (planar X, Y components), got {arr.shape}"
        )
    return arr


def _positive(name: str, arr: np.ndarray, error: type[Exception] = InputError) -> None:
    if np.any(arr <= 0.0):
        bad = float(arr[arr <= 0.0].ravel()[0])
        raise error(f"{name} must be > 0 m, got {bad!r}")


def _check_wheel(r: np.ndarray, d: np.ndarray, error: type[Exception] = InputError) -> None:
    _positive("r", r, error)
    _positive("d", d, error)
    r_b, d_b = np.broadcast_arrays(r, d)
    bad = r_b >= d_b
    if np.any(bad):
        rb, db = float(r_b[bad].ravel()[0]), float(d_b[bad].ravel()[0])
        where = (
            "the pin B reaches the collar pivot C at theta = 0 (L = 0)"
            if rb == db
            else "the collar pivot C lies inside the wheel rim"
        )
        raise DegenerateGeometryError(f"{where}: r = {rb!r} m, d = {db!r} m; need 0 < r < d")


def _stack(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.stack(np.broadcast_arrays(x, y), axis=-1)
