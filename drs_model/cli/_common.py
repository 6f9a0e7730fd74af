"""Shared pieces of the ``drs`` subcommands: parameter loading, JSON and table output."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, ParameterError
from ..overrides import (
    apply_overrides,
    assignment_argument,
    assignment_overrides,
    file_overrides,
    parameter_file_argument,
    split_overrides,
)
from ..params import DRSParams


@dataclass
class Output:
    """What a subcommand returns: machine-readable ``data`` and a human ``text`` rendering."""

    data: dict[str, Any]
    text: str


def add_json(parser: argparse.ArgumentParser) -> None:
    """``--json`` for every subcommand."""
    parser.add_argument("--json", action="store_true", help="print machine-readable JSON")


def add_common(parser: argparse.ArgumentParser) -> None:
    """``--json``, ``--params FILE`` and ``--set NAME=VALUE`` for the subcommands of the DRS
    model (the Coriolis examples take their own options)."""
    add_json(parser)
    parser.add_argument(
        "--params",
        metavar="FILE",
        type=parameter_file_argument,
        help="TOML/YAML file of DRSParams (and, where a hydraulic rung runs, "
        "HydraulicParams) overrides",
    )
    parser.add_argument(
        "--set",
        metavar="NAME=VALUE",
        action="append",
        default=[],
        type=assignment_argument,
        help="override one DRSParams value (repeatable), e.g. --set Iz_wing=0.08; where a "
        "hydraulic rung runs, a HydraulicParams one too, e.g. --set leak_to_outside=1e-12",
    )


def _given_values(args: argparse.Namespace) -> tuple[dict, dict]:
    """``--params FILE``'s values, then ``--set``'s: (model, hydraulic) overrides."""
    values = dict(file_overrides(args.params)) if getattr(args, "params", None) else {}
    values.update(assignment_overrides(getattr(args, "set", []) or []))
    return split_overrides(values)


def load_params(args: argparse.Namespace) -> DRSParams:
    """The DRSParams of ``--params`` and ``--set``, for a subcommand that runs no hydraulic rung:
    a hydraulic value given to it is refused (it would change nothing)."""
    model, hydraulic = _given_values(args)
    if hydraulic:
        raise ParameterError(
            f"{sorted(hydraulic)}: hydraulic parameters, and this command runs no hydraulic rung"
        )
    return apply_overrides(model)[0]


def load_both(args: argparse.Namespace):
    """The DRSParams and HydraulicParams of ``--params`` and ``--set`` (a subcommand that runs
    the hydraulic rung: ``drs excite``, ``drs fidelity``)."""
    model, hydraulic = _given_values(args)
    return apply_overrides({**model, **{f"hydraulic.{k}": v for k, v in hydraulic.items()}})


def float_list(text: str) -> list[float]:
    """Parse ``"0.001,0.002"`` into floats (argparse ``type=``)."""
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}"
        ) from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    return values


def parameter_names_argument(text: str) -> list[str]:
    """argparse ``type=`` of ``NAME,...`` (``drs excite``, ``drs-bag fit`` and ``trend``'s
    ``--params``): at least one name, none twice."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("name at least one parameter")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise argparse.ArgumentTypeError(f"named twice: {repeated}")
    return names


def fit_names_argument(text: str) -> list[str]:
    """argparse ``type=`` of ``NAME,...``: parameters that can be fitted, none twice (whether
    a design or a fit can serve them is the model's to say)."""
    from ..identify.parameters import fit_parameter

    names = parameter_names_argument(text)
    try:
        for name in names:
            fit_parameter(name)
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return names


def positive_number(text: str) -> float:
    """argparse ``type=``: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def output_path(text: str) -> str:
    """argparse ``type=`` of a file or directory to write: its directory exists (a mistyped
    directory is a usage error, status 2 before anything runs, not a tree created behind the
    user's back)."""
    parent = Path(text).parent
    if not parent.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r}: no directory {str(parent)!r}")
    return text


def output_file_type(*suffixes: str) -> Callable[[str], str]:
    """argparse ``type=`` of a file to write: its name ends in one of ``suffixes`` and its
    directory exists (:func:`output_path`)."""
    kinds = " or ".join(suffixes)

    def check(text: str) -> str:
        if Path(text).suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(
                f"{text!r}: the output is a {kinds} file, its name ends in {kinds}"
            )
        return output_path(text)

    check.__name__ = f"{'_'.join(s.strip('.') for s in suffixes)}_output_path"
    return check


#: argparse ``type=`` of a PNG to write (``--plot``, ``drs draw --out``).
png_output_path = output_file_type(".png")


def positive_integer(text: str) -> int:
    """argparse ``type=``: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def finite(name: str, value: float) -> float:
    if not math.isfinite(value):
        raise InputError(f"{name} must be finite, got {value!r}")
    return value


def jsonable(obj: Any) -> Any:
    """numpy arrays/scalars to lists/floats; NaN/inf to None (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def dumps(data: dict[str, Any]) -> str:
    return json.dumps(jsonable(data), indent=2, allow_nan=False)


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]], fmt: str = "{:.9g}") -> str:
    """A plain aligned text table."""

    def cell(v: Any) -> str:
        if isinstance(v, (float, np.floating)):
            return fmt.format(float(v))
        return str(v)

    body = [[cell(v) for v in row] for row in rows]
    widths = [
        max(len(h), *(len(r[i]) for r in body)) if body else len(h) for i, h in enumerate(headers)
    ]
    line = "  ".join(h.rjust(w) for h, w in zip(headers, widths, strict=True))
    sep = "  ".join("-" * w for w in widths)
    out = [line, sep] + [
        "  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in body
    ]
    return "\n".join(out)


def key_values(pairs: Sequence[tuple[str, Any, str]]) -> str:
    """``name  value  unit`` lines."""
    rows = [(k, v, u) for k, v, u in pairs]
    return table(("quantity", "value", "unit"), rows)


Runner = Callable[[argparse.Namespace], Output]
