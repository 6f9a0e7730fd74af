"""The model's parameters as the node serves and records them: ``model.<DRSParams field>`` and
``hydraulic.<HydraulicParams field>``, at the values the model runs (a derived inertia as
derived, the valve's port ratio as the number run). One table for the node
(:mod:`drs_ros.node.parameters`), the bags it writes and a re-run's bag
(:mod:`drs_ros.bag.replay.rerun_bag`); :func:`drs_ros.bag.read.effects.model_params_from` and
``hydraulic_params_from`` read them back.
"""

from __future__ import annotations

from drs_model.fidelity.hydraulic_params import HYDRAULIC_FIELDS, HydraulicParams
from drs_model.params import NUMERIC_FIELDS, DRSParams

#: The model's parameters the node serves: ``model.<DRSParams field>``, then
#: ``hydraulic.<HydraulicParams field>``.
MODEL_PARAMETERS = (
    *(f"model.{name}" for name in NUMERIC_FIELDS),
    *(f"hydraulic.{name}" for name in HYDRAULIC_FIELDS),
)


def served_value(name: str, params: DRSParams, hydraulic: HydraulicParams) -> float | str:
    """The value the model runs for parameter ``name`` (one of :data:`MODEL_PARAMETERS`), SI."""
    owner, field = name.split(".", 1)
    if owner == "model":
        return float(getattr(params, field))
    if field == "valve_port_ratio":
        return float(hydraulic.port_ratio)  # None means the area ratio: the number run
    value = getattr(hydraulic, field)
    return value if isinstance(value, str) else float(value)


def served_values(params: DRSParams, hydraulic: HydraulicParams) -> dict[str, float | str]:
    """Every one of :data:`MODEL_PARAMETERS` at the value the model runs."""
    return {name: served_value(name, params, hydraulic) for name in MODEL_PARAMETERS}


__all__ = ["MODEL_PARAMETERS", "served_value", "served_values"]
