"""Parameter overrides from text: the ``--set NAME=VALUE`` items of the command lines and the
TOML/YAML parameter files (of ``drs``, ``drs-bag`` and the node's ``model_params_file``).

Each parser returns the ``name: value`` pairs it read; :func:`drs_model.params.from_dict` checks
the names and values when it applies them. A name is a :class:`~drs_model.params.DRSParams` field
or a :class:`~drs_model.fidelity.hydraulic_params.HydraulicParams` field (the two share no name),
bare or as the node names it (``model.m_wing``, ``hydraulic.leak_to_outside``);
:func:`split_overrides` sorts them and :func:`apply_overrides` applies both.
:func:`parameter_file_argument` and :func:`assignment_argument` are the argparse ``type=`` of
``--params`` and ``--set``: a file that cannot be read or parsed, or names no parameter, is
argparse's usage error naming the option, before a tool reads anything else.
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
    """Parameters from ``base`` (default: the seed) with the model overrides of a TOML
    (``.toml``) or YAML (``.yaml``/``.yml``) file applied (:func:`file_overrides`); its hydraulic
    values, if any, are :func:`both_from_file`'s."""
    return from_dict(split_overrides(file_overrides(path))[0], base=base)


def _hydraulic_fields() -> tuple[str, ...]:
    # imported here: drs_model.fidelity loads the compiled kernels, which a tool that only
    # parses its options does not need
    from .fidelity.hydraulic_params import HYDRAULIC_FIELDS

    return HYDRAULIC_FIELDS


def split_overrides(values: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``values`` sorted into DRSParams and HydraulicParams overrides (bare names, or prefixed
    ``model.`` / ``hydraulic.``); a name that is neither stays with the model's, whose check
    refuses it with the valid names."""
    hydraulic_fields = _hydraulic_fields()
    model: dict[str, Any] = {}
    hydraulic: dict[str, Any] = {}
    for name, value in values.items():
        bare = name.removeprefix("model.").removeprefix("hydraulic.")
        if bare in hydraulic_fields and not name.startswith("model."):
            hydraulic[bare] = value
        else:
            model[bare if name.startswith("model.") else name] = value
    return model, hydraulic


def apply_overrides(
    values: Mapping[str, Any], model: DRSParams | None = None, hydraulic=None
) -> tuple[DRSParams, Any]:
    """``model`` and ``hydraulic`` (default: the seed's and HydraulicParams' defaults) with
    ``values`` applied (:func:`split_overrides`), each checked by its dataclass."""
    from .fidelity.hydraulic_params import hydraulic_from_dict

    model_values, hydraulic_values = split_overrides(values)
    model = from_dict(model_values, base=model) if model_values or model is None else model
    return model, hydraulic_from_dict(hydraulic_values, base=hydraulic)


def both_from_file(
    path: str | Path, model: DRSParams | None = None, hydraulic=None
) -> tuple[DRSParams, Any]:
    """:func:`apply_overrides` with a parameter file's values: DRSParams and HydraulicParams."""
    return apply_overrides(file_overrides(path), model, hydraulic)


def assignment_overrides(items) -> dict[str, float]:
    """Overrides from ``NAME=VALUE`` strings (the ``--set`` option of the command lines).

    Raises :class:`ParameterError` for an item without ``=`` or a value that is no number (the
    names are checked where the overrides are applied, :func:`from_dict`).
    """
    overrides: dict[str, float | str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise ParameterError(f"--set expects NAME=VALUE, got {item!r}")
        name = name.strip()
        if name.removeprefix("hydraulic.") == "flow_law":  # the one parameter that is a word
            overrides[name] = value.strip()
            continue
        try:
            overrides[name] = float(value)
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
        raise ParameterError(
            f"cannot read parameter file {str(path)!r}: not UTF-8 text "
            f"(byte 0x{exc.object[exc.start]:02x} at {exc.start})"
        ) from None
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
        raise ParameterError(
            f"cannot parse parameter file {str(path)!r}: {parse_error_text(exc)}"
        ) from exc
    if isinstance(data, Mapping) and "drs" in data and isinstance(data["drs"], Mapping):
        data = data["drs"]
    if not isinstance(data, Mapping):
        raise ParameterError(f"parameter file {str(path)!r} must hold a table of name = value")
    return dict(data)


def parse_error_text(exc: Exception) -> str:
    """A parser's error (YAML's, TOML's) as one line: YAML's problem and where (line, column,
    from 1), not its several lines of context with a caret; any other error's words on one line.
    A start-up error is one line on stderr (docs/cli.md)."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None)
    if problem and mark is not None:
        return f"{problem} at line {mark.line + 1}, column {mark.column + 1}"
    return " ".join(str(exc).split()) or type(exc).__name__


def _known_names(names) -> None:
    model = {f.name for f in dataclasses.fields(DRSParams)}
    hydraulic = set(_hydraulic_fields())
    known = model | hydraulic | {f"model.{n}" for n in model}
    known |= {f"hydraulic.{n}" for n in hydraulic}
    unknown = sorted(set(names) - known)
    if unknown:
        raise ParameterError(
            f"unknown parameter(s) {unknown}; valid names: {sorted(model)} "
            f"and the hydraulic {sorted(hydraulic)}"
        )


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
