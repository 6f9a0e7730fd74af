"""``drs-bag fit --set`` reads names as ``drs-bag resimulate --set`` does (the one parser of
:mod:`drs_model.overrides`): bare, ``model.``- or ``hydraulic.``-prefixed, and ``flow_law``."""

from __future__ import annotations

import argparse
from types import SimpleNamespace

import pytest

from drs_model.fidelity import HydraulicParams
from drs_model.params import DRSParams
from drs_ros.bag.season.fit import _models, set_argument


@pytest.mark.parametrize(
    "item",
    [
        "hydraulic.leak_to_outside=2e-13",
        "leak_to_outside=2e-13",
        "model.m_wing=2.5",
        "m_wing=2.5",
        "flow_law=linear",
        "hydraulic.flow_law=linear",
    ],
)
def test_set_takes_the_names_resimulate_takes(item):
    assert set_argument(item) == item


@pytest.mark.parametrize(
    ("item", "reason"),
    [
        ("hydraulic.m_wing=2", "'hydraulic.m_wing' is no hydraulic parameter"),
        ("model.leak_to_outside=1", "'leak_to_outside' is no model parameter"),
        ("bogus=1", "'bogus' is no model or hydraulic parameter"),
        ("hydraulic.leak_to_outside=wet", "is not a number"),
    ],
)
def test_set_refuses_a_name_of_no_parameter_with_the_reason(item, reason):
    with pytest.raises(argparse.ArgumentTypeError, match=reason):
        set_argument(item)


def _measured(**recorded):
    return SimpleNamespace(params=DRSParams(), node_parameters=recorded or None)


def test_prefixed_and_bare_names_set_the_same_start():
    recorded = _measured(**{"hydraulic.viscous_friction": 70.0})
    prefixed = _models(
        recorded,
        ["hydraulic.leak_to_outside=2e-13", "model.m_wing=2.5", "hydraulic.flow_law=linear"],
    )
    bare = _models(recorded, ["leak_to_outside=2e-13", "m_wing=2.5", "flow_law=linear"])
    assert prefixed == bare
    p, hp = prefixed
    assert hp == HydraulicParams(
        leak_to_outside=2e-13, viscous_friction=70.0, flow_law="linear"
    )  # the recorded value kept
    assert p.m_wing == 2.5


def test_a_flow_law_of_none_is_refused_by_the_model():
    from drs_model.errors import ParameterError

    with pytest.raises(ParameterError, match="flow_law must be one of"):
        _models(_measured(), ["flow_law=sticky"])
