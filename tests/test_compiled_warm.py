"""``python -m drs_model.compiled`` and :func:`drs_model.compiled.warm.warm_up`: the shares that
processes compiling at once take (``make`` runs two) cover every step exactly once, and a share
that does not exist is refused with its range."""

from __future__ import annotations

import importlib.util
import os

import pytest

if importlib.util.find_spec("numba") is None:
    if os.environ.get("CI"):
        pytest.fail("numba is required under CI (pip install -e '.[fast]')", pytrace=False)
    pytest.skip("numba is not installed (pip install drs[fast])", allow_module_level=True)

from drs_model.compiled import __main__ as cli  # noqa: E402
from drs_model.compiled import warm  # noqa: E402


@pytest.mark.parametrize("parts", [1, 2, 3, 5])
def test_the_shares_together_compile_every_step_once(monkeypatch, params, parts):
    calls = []
    steps = tuple((lambda p, k=k: calls.append((k, p))) for k in range(len(warm.WARM_STEPS) + 2))
    monkeypatch.setattr(warm, "WARM_STEPS", steps)
    for part in range(parts):
        warm.warm_up(params, part=part, parts=parts)
    assert sorted(k for k, _ in calls) == list(range(len(steps)))
    assert all(p is params for _, p in calls)


def test_every_step_of_the_compiled_functions_is_a_share():
    assert len(warm.WARM_STEPS) >= 2 and all(callable(step) for step in warm.WARM_STEPS)


@pytest.mark.parametrize(("part", "parts"), [(2, 2), (-1, 2), (0, 0)])
def test_a_share_out_of_range_is_refused(params, part, parts):
    with pytest.raises(ValueError, match=f"part {part} is not in 0..{parts - 1}"):
        warm.warm_up(params, part=part, parts=parts)


@pytest.mark.parametrize("bad", ["0/2", "3/2", "x", "1/2/3", "1/"])
def test_the_command_refuses_a_share_that_is_not_i_of_n(bad, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--part", bad])
    assert exc.value.code == 2
    assert repr(bad) in capsys.readouterr().err


def test_the_command_compiles_its_share(monkeypatch, capsys):
    seen = []
    monkeypatch.setattr(warm, "warm_up", lambda part, parts: seen.append((part, parts)) or 0.5)
    assert cli.main(["--part", "2/2"]) == 0
    assert seen == [(1, 2)]
    assert "share 2/2" in capsys.readouterr().out
