"""Parameter overrides from text: the ``--set NAME=VALUE`` items of the command lines and the
TOML/YAML parameter files (of ``drs``, ``drs-bag`` and the node's ``model_params_file``).

Each parser returns the ``name: value`` pairs it read; :func:`drs_model.params.from_dict` checks
the names and values when it applies them. :func:`parameter_file_argument` and
:func:`assignment_argument` are the argparse ``type=`` of ``--params`` and ``--set``: a file
that cannot be read or parsed, or names no parameter, is argparse's usage error naming the
option, before a tool reads anything else.
"""

from __future__ import annotations

import argparse
import dataclasses
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .errors import ParameterError
from .params import DRSParams, from_dict


def from_file(path: str | Path, base: DRSParams | None = None) -> DRSParams:
    """Parameters from ``base`` (default: the seed) with the overrides of a TOML (``.toml``) or
    YAML (``.yaml``/``.yml``) file applied (:func:`file_overrides`)."""
    return from_dict(file_overrides(path), base=base)


def assignment_overrides(items) -> dict[str, float]:
    """Overrides from ``NAME=VALUE`` strings (the ``--set`` option of the command lines).

    Raises :class:`ParameterError` for an item without ``=`` or a value that is no number (the
    names are checked where the overrides are applied, :func:`from_dict`).
    """
    overrides: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise ParameterError(f"--set expects NAME=VALUE, got {item!r}")
        try:
            overrides[name.strip()] = float(value)
        except ValueError:
            raise ParameterError(f"--set {name}: {value!r} is not a number") from None
    return overrides


def file_overrides(path: str | Path) -> dict[str, Any]:
    """The ``name = value`` pairs of a TOML or YAML parameter file (at top level or under a
    ``[drs]`` table), not yet checked (:func:`from_dict` checks them)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ParameterError(f"cannot read parameter file {str(path)!r}: {exc}") from exc
    except UnicodeDecodeError as exc:
        raise ParameterError(f"cannot read parameter file {str(path)!r}: not UTF-8 text "
                             f"(byte 0x{exc.object[exc.start]:02x} at {exc.start})") from None
    suffix = path.suffix.lower()
    try:
        if suffix == ".toml":
            data = tomllib.loads(text)
        elif suffix in (".yaml", ".yml"):
            try:
                import yaml  # optional: installed with the ros extra
            except ImportError:
                raise ParameterError(
                    f"reading {str(path)!r} needs pyyaml (pip install pyyaml, or 'drs[ros]'); "
                    "a .toml file needs nothing extra"
                ) from None
            data = yaml.safe_load(text) or {}
        else:
            raise ParameterError(f"parameter file {str(path)!r} must end in .toml, .yaml or .yml")
    except ParameterError:
        raise
    except Exception as exc:  # noqa: BLE001 - any parser error becomes a ParameterError
        raise ParameterError(f"cannot parse parameter file {str(path)!r}: {exc}") from exc
    if isinstance(data, Mapping) and "drs" in data and isinstance(data["drs"], Mapping):
        data = data["drs"]
    if not isinstance(data, Mapping):
        raise ParameterError(f"parameter file {str(path)!r} must hold a table of name = value")
    return dict(data)


def _known_names(names) -> None:
    known = {f.name for f in dataclasses.fields(DRSParams)}
    unknown = sorted(set(names) - known)
    if unknown:
        raise ParameterError(f"unknown parameter(s) {unknown}; valid names: {sorted(known)}")


def parameter_file_argument(path: str) -> str:
    """argparse ``type=`` of ``--params FILE``: ``path``, once the file reads and parses as a
    table of known parameter names (their values are checked where they are applied, with the
    parameters they join). Otherwise :class:`argparse.ArgumentTypeError` (argparse's usage error,
    ``argument --params: ...``, exit status 2)."""
    try:
        _known_names(file_overrides(path))
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return path


def assignment_argument(item: str) -> str:
    """argparse ``type=`` of ``--set NAME=VALUE``: ``item``, once it has the form, names a
    parameter and its value is a number; otherwise :class:`argparse.ArgumentTypeError`."""
    try:
        _known_names(assignment_overrides([item]))
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return item
