"""drs study: the spec and its errors, the design, Sobol' indices on a known function, and whole
studies on a real embedded Dask cluster (1 and 2 workers), through the command line too."""

from __future__ import annotations

import contextlib
import io
import json
import textwrap

import numpy as np
import pyarrow.parquet as pq
import pytest

from drs_model.cli import main as drs_main
from drs_model.errors import ParameterError, StudySpecError
from drs_model.params import NUMERIC_FIELDS, DRSParams
from drs_model.study import RESULT_COLUMNS, Normal, Uniform, parse_spec, read_spec, run_study
from drs_model.study.design import design
from drs_model.study.sensitivity import sobol

SPEC = {
    "sampler": {"method": "lhs", "samples": 40, "seed": 7, "sensitivity": True},
    "scene": {"grid": 1001, "rtol": 1e-8},
    "parameters": {
        "L2": {"distribution": "normal", "std": 2e-5},
        "m_wing": {"distribution": "uniform", "low": 1.9, "high": 2.1},
        "y_D": {"distribution": "normal", "mean": 0.154, "std": 4e-5},
        # wide enough that some samples do not assemble at the design's closed stroke
        "L3": {"distribution": "uniform", "low": 0.085, "high": 0.105},
    },
}


# ---- the spec ---------------------------------------------------------------------------------
def test_a_spec_reads_as_written():
    spec = parse_spec(SPEC)
    assert spec.fields == ("L2", "m_wing", "y_D", "L3")
    assert spec.distributions[0] == Normal(DRSParams().L2, 2e-5)  # mean: the design's value
    assert spec.distributions[1] == Uniform(1.9, 2.1)
    assert (spec.sampler, spec.samples, spec.seed, spec.runs) == ("lhs", 40, 7, 40 * 6)
    assert (spec.scene.grid, spec.scene.rtol, spec.scene.opening_force) == (1001, 1e-8, 3000.0)


def test_the_example_spec_reads(tmp_path):
    spec = read_spec("config/study.toml")
    assert spec.sampler == "sobol" and spec.runs == 256 * (len(spec.fields) + 2)


def _with(path: str, value) -> dict:
    data = json.loads(json.dumps(SPEC))
    *heads, last = path.split(".")
    node = data
    for h in heads:
        node = node[h]
    if value is None:
        del node[last]
    else:
        node[last] = value
    return data


@pytest.mark.parametrize(
    ("path", "value", "match"),
    [
        (
            "parameters.L22",
            {"distribution": "normal", "std": 1.0},
            r"\[parameters.L22\]: 'L22' is not a DRSParams field; valid fields: \['box_height'",
        ),
        (
            "parameters.L2.distribution",
            "gaussian",
            r"unknown distribution 'gaussian'; valid distributions: \['uniform', 'normal'\]",
        ),
        ("parameters.L2.distribution", None, r"\[parameters.L2\] needs distribution = one of"),
        (
            "parameters.L2.sigma",
            1e-5,
            r"\[parameters.L2\] \(normal\): unknown key\(s\) \['sigma'\]; valid keys: ",
        ),
        ("parameters.m_wing.high", None, r"\[parameters.m_wing\] \(uniform\): missing key"),
        ("parameters.m_wing.high", 1.8, r"\[parameters.m_wing\]: uniform needs low < high"),
        ("parameters.L2.std", -1e-5, r"\[parameters.L2\]: normal needs std > 0, got std=-1e-05"),
        ("parameters.L2.std", "small", r"\[parameters.L2\] std must be a number, got 'small'"),
        ("sampler.method", "halton", r"method must be one of \['lhs', 'sobol'\], got 'halton'"),
        ("sampler.samples", 1, r"samples must be a whole number >= 2, got 1"),
        ("sampler.seed", -3, r"seed must be a whole number >= 0, got -3"),
        ("sampler.sensitivity", "yes", r"sensitivity must be true or false, got 'yes'"),
        ("sampler.n", 3, r"\[sampler\]: unknown key\(s\) \['n'\]; valid keys: \['method'"),
        ("scene.horizon", 0.0, r"horizon must be > 0 s, got 0.0"),
        ("scene.force", 1.0, r"\[scene\]: unknown key\(s\) \['force'\]; valid keys"),
        ("scene.grid", 2, r"grid must be a whole number >= 3, got 2"),
        ("samplers", {}, r"the spec: unknown key\(s\) \['samplers'\]; valid keys"),
        ("parameters", {}, r"a study varies at least one parameter"),
    ],
)
def test_spec_errors_name_the_value_and_the_valid_ones(path, value, match):
    with pytest.raises(StudySpecError, match=match):
        parse_spec(_with(path, value))


def test_the_valid_fields_are_listed_and_the_design_is_checked():
    with pytest.raises(StudySpecError) as exc:
        parse_spec(_with("parameters.bogus", {"distribution": "normal", "std": 1.0}))
    assert all(repr(name) in str(exc.value) for name in NUMERIC_FIELDS)
    with pytest.raises(StudySpecError, match=r"\[design\]: unknown key\(s\) \['L9'\]"):
        parse_spec(_with("design", {"L9": 1.0}))
    with pytest.raises(ParameterError, match="L2 must be > 0 m, got -0.05"):
        parse_spec(_with("design", {"L2": -0.05}))


def test_a_file_that_is_not_toml_says_so(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[sampler\nmethod = 1\n")
    with pytest.raises(StudySpecError, match="is not valid TOML"):
        read_spec(bad)
    with pytest.raises(StudySpecError, match="cannot read study spec"):
        read_spec(tmp_path / "missing.toml")


def test_the_command_line_prints_a_spec_error_and_exits_2(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text('[parameters.Lx]\ndistribution = "normal"\nstd = 1.0\n')
    assert drs_main(["study", str(spec), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "drs study: error: [parameters.Lx]: 'Lx' is not a DRSParams field" in err
    assert not (tmp_path / "out").exists()


# ---- the design and the indices ----------------------------------------------------------------
def test_the_design_is_seeded_and_pick_freeze():
    spec = parse_spec(SPEC)
    one, two = design(spec), design(spec)
    assert np.array_equal(one.values, two.values)
    other = design(parse_spec(_with("sampler.seed", 8)))
    assert not np.array_equal(one.values, other.values)
    n, d = spec.samples, len(spec.fields)
    a, b = one.unit[:n], one.unit[n : 2 * n]
    for i in range(d):
        ab = one.unit[(2 + i) * n : (3 + i) * n]
        assert np.array_equal(ab[:, i], b[:, i])
        assert np.array_equal(np.delete(ab, i, axis=1), np.delete(a, i, axis=1))
    # a Latin hypercube: each of the n strata of each column holds one point of A
    assert all(np.array_equal(np.sort(np.floor(a[:, i] * n)), np.arange(n)) for i in range(d))
    m = one.values[:, 1]
    assert m.min() >= 1.9 and m.max() <= 2.1


@pytest.mark.parametrize("method", ["lhs", "sobol"])
def test_sobol_indices_of_a_known_function(method):
    """``f = x1 + 2 x2 + x1 x3`` with independent uniforms on [0, 1]: the variance shares
    follow from the ANOVA decomposition (V1 = 1/48 + 1/12 ... , below), computed by hand."""
    data = {
        "sampler": {"method": method, "samples": 4096, "seed": 3},
        "parameters": {
            name: {"distribution": "uniform", "low": 0.0 + k, "high": 1.0 + k}
            for name, k in (("m_wing", 1.0), ("m_link", 0.0), ("m_pist", 0.0))
        },
    }
    data["parameters"]["m_link"]["low"] = 1e-3  # masses must be > 0; nearly [0, 1]
    spec = parse_spec(data)
    rows = design(spec)
    x1, x2, x3 = rows.values[:, 0] - 1.0, rows.values[:, 1], rows.values[:, 2]
    f = x1 + 2.0 * x2 + x1 * x3
    # E[x] = 1/2, Var[x] = 1/12; f1 = x1 (1 + 1/2), f3 = (x3 - 1/2) / 2, f13 = (x1-1/2)(x3-1/2)
    v1, v2, v3, v13 = 2.25 / 12, 4.0 / 12, 0.25 / 12, 1.0 / 144
    total = v1 + v2 + v3 + v13
    got = sobol(f, rows.block, spec.fields)
    assert got.groups == 4096
    np.testing.assert_allclose(got.first_order, [v1 / total, v2 / total, v3 / total], atol=0.03)
    np.testing.assert_allclose(
        got.total_order, [(v1 + v13) / total, v2 / total, (v3 + v13) / total], atol=0.03
    )


# ---- whole studies on Dask ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def one_and_two_workers():
    spec = parse_spec(SPEC)
    return (
        spec,
        run_study(spec, jobs=1, chunk=32, progress=False),
        run_study(spec, jobs=2, chunk=32, progress=False),
    )


def test_one_and_two_workers_give_the_same_numbers(one_and_two_workers):
    spec, one, two = one_and_two_workers
    assert one.columns["sample"].size == spec.runs == 240
    for name, col in one.columns.items():
        if col.dtype == object:
            assert list(col) == list(two.columns[name]), name
        else:
            assert np.array_equal(col, two.columns[name], equal_nan=True), name
    for name, ind in one.indices.items():
        if ind is not None:
            assert np.array_equal(ind.total_order, two.indices[name].total_order)


def test_a_study_has_every_row_and_says_why_a_row_has_no_result(one_and_two_workers):
    spec, one, _ = one_and_two_workers
    failed = np.array([e is not None for e in one.columns["error"]])
    assert 0 < failed.sum() < spec.runs  # some L3 samples do not reach the closed stop
    for name in RESULT_COLUMNS:
        assert np.isnan(one.columns[name][failed]).all()
        if not name.endswith("_time") or name in ("peak_time", "lowest_time"):
            assert np.isfinite(one.columns[name][~failed]).all(), name
    assert all("cannot close" in e for e in one.columns["error"][failed])
    # near the dead centre a forward run may not finish: its time is NaN and its status says why
    for run in ("opening", "closing"):
        status = one.columns[f"{run}_status"][~failed]
        times = one.columns[f"{run}_time"][~failed]
        done = status == "ok"
        assert np.isfinite(times[done]).all() and np.isnan(times[~done]).all()
        assert set(status[~done]) <= {
            "moves away from the stop",
            "integration failed: the link turned horizontal (cos psi1 < 0.05)",
        }


def test_the_command_line_writes_the_table_and_the_figures(tmp_path):
    spec = tmp_path / "study.toml"
    spec.write_text(
        textwrap.dedent(
            """
            [sampler]
            method = "sobol"
            samples = 16
            seed = 5

            [scene]
            grid = 501

            [parameters.m_wing]
            distribution = "uniform"
            low = 1.9
            high = 2.1

            [parameters.y_D]
            distribution = "normal"
            std = 4e-5
            """
        )
    )
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = drs_main(["study", str(spec), "--jobs", "1", "-o", str(tmp_path / "o"), "--json"])
    assert code == 0
    data = json.loads(out.getvalue())
    assert data["runs"] == 16 * 4 and data["failed"] == 0
    table = pq.read_table(tmp_path / "o" / "study.parquet")
    assert table.num_rows == 64
    assert {"sample", "block", "m_wing", "y_D", *RESULT_COLUMNS, "error"} <= set(table.column_names)
    meta = json.loads(table.schema.metadata[b"drs.study"])
    assert meta["seed"] == 5 and meta["parameters"]["y_D"]["distribution"] == "normal"
    assert data["results"]["peak_force"]["max"] == pytest.approx(
        max(table.column("peak_force").to_pylist()), rel=0
    )
    import matplotlib.image

    for name in ("histograms.png", "sensitivity.png"):
        image = matplotlib.image.imread(tmp_path / "o" / name)  # a PNG a reader opens
        assert image.shape[0] > 200 and image.shape[1] > 400
    ranking = data["sensitivity"]["opening_time"]
    assert ranking[0]["field"] == "m_wing"  # a heavier flap opens slower; y_D moves it little
