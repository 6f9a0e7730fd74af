"""The two roots of drs's errors (drs_model.errors.DRSError, drs_ros.errors.DRSRosError) and the
one table of exit statuses (drs_model.cli.exit_status, docs/cli.md): each tool reports a bad
option as a usage error naming the option (never as a bad bag), a damaged bag as a bag error, a
model refusal at start as a refusal naming the parameter, and an error while the node runs as no
refusal to start."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from node_support import domain_for, node_env
from ros_support import require_rclpy

from drs_model.cli import exit_status
from drs_model.cli import main as drs_main
from drs_model.errors import DRSError
from drs_ros.node.command_line import node_command

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "bags" / "example"


def _exception_classes(package: str):
    """Every exception class defined in the modules of ``package`` (``__main__`` modules, which
    run a tool when imported, left out)."""
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__main__":
            continue
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        module = importlib.import_module(name)
        for obj in vars(module).values():
            if inspect.isclass(obj) and issubclass(obj, BaseException) and obj.__module__ == name:
                yield obj


def test_every_model_error_is_a_drs_error():
    classes = list(_exception_classes("drs_model"))
    assert len(classes) > 10
    assert [c for c in classes if not issubclass(c, DRSError)] == []


def test_drs_ros_errors_have_their_own_root():
    require_rclpy()
    from drs_ros.errors import DRSRosError

    classes = list(_exception_classes("drs_ros"))
    assert {"BagReadError", "RecordingError", "StartupError", "PlayError"} <= {
        c.__name__ for c in classes
    }
    assert [c for c in classes if not issubclass(c, DRSRosError)] == []
    assert [c for c in classes if issubclass(c, DRSError)] == []


#: The command-line modules and the functions whose return value is a process's exit status.
CLI_FUNCTIONS = {
    "drs_model/cli/__init__.py": ("main",),
    "drs_ros/bag/cli.py": ("main", "check_alias"),
    "drs_ros/bag/check/command.py": ("main", "run"),
    "drs_ros/bag/recover.py": ("run",),
    "drs_ros/bag/replay/resimulate.py": ("run",),
    "drs_ros/bag/info.py": ("run",),
    "drs_ros/bag/season/catalogue.py": ("run",),
    "drs_ros/bag/season/fit.py": ("run",),
    "drs_ros/bag/season/trend.py": ("run",),
    "drs_ros/bag/from_goal.py": ("run",),
    "drs_ros/bag/season/fleet.py": ("run_fleet",),
    "drs_ros/bag/replay/play/player.py": ("play", "run", "main"),
    "drs_ros/node/runner.py": ("main",),
    "drs_ros/demo.py": ("main",),
}


def _literal_statuses(node: ast.AST) -> list[int]:
    """Integer literals a returned expression can give (``0``, ``0 if ok else 1``)."""
    if isinstance(node, ast.Constant) and type(node.value) is int:
        return [node.value]
    if isinstance(node, ast.IfExp):
        return _literal_statuses(node.body) + _literal_statuses(node.orelse)
    return []


@pytest.mark.parametrize("path", sorted(CLI_FUNCTIONS))
def test_exit_statuses_come_from_one_place(path):
    """No command line returns a number of its own: every status is a constant of
    drs_model.cli.exit_status (and so in the one table of docs/cli.md)."""
    tree = ast.parse((ROOT / path).read_text())
    found = []
    for fn in tree.body:  # the module's functions, not a class's methods of the same name
        if isinstance(fn, ast.FunctionDef) and fn.name in CLI_FUNCTIONS[path]:
            found.append(fn.name)
            for node in ast.walk(fn):
                if isinstance(node, ast.Return) and node.value is not None:
                    assert _literal_statuses(node.value) == [], (
                        f"{path}:{node.lineno} {fn.name} returns a literal exit status"
                    )
    assert sorted(found) == sorted(CLI_FUNCTIONS[path])


def test_the_documented_table_is_the_constants():
    text = (ROOT / "docs" / "cli.md").read_text()
    rows = re.findall(r"^\| (\d) \| ", text, flags=re.M)
    constants = {v for k, v in vars(exit_status).items() if k.startswith("EXIT_")}
    assert sorted(int(r) for r in rows) == sorted(constants)


# ---- drs ----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("argv", "option", "match"),
    [
        (["limits", "--params", "no/such/file.toml"], "--params", "cannot read parameter file"),
        (["limits", "--set", "L2"], "--set", "--set expects NAME=VALUE"),
        (["limits", "--set", "L22=0.1"], "--set", r"unknown parameter\(s\) \['L22'\]"),
    ],
)
def test_drs_bad_option_is_a_usage_error_naming_it(capsys, argv, option, match):
    with pytest.raises(SystemExit) as exc:
        drs_main(argv)
    assert exc.value.code == exit_status.EXIT_USAGE
    err = capsys.readouterr().err
    assert err.startswith("usage: drs limits")
    assert re.search(rf"drs limits: error: argument {option}: .*{match}", err)


def test_drs_model_refusal_is_one_line(capsys):
    assert drs_main(["limits", "--set", "L2=-1"]) == exit_status.EXIT_REFUSED
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "L2 must be > 0 m" in err and "usage" not in err


# ---- drs-bag ------------------------------------------------------------------------------------
def _bag_tool(capsys, *argv) -> tuple[int, str]:
    require_rclpy()
    from drs_ros.bag.cli import main

    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:
        status = exc.code
    captured = capsys.readouterr()
    return status, captured.err + captured.out


@pytest.fixture
def unknown_params(tmp_path):
    path = tmp_path / "typo.toml"
    path.write_text("m_wingg = 3.0\n")
    return path


@pytest.mark.parametrize("fleet", [False, True])
def test_check_bad_params_is_a_usage_error_not_an_unreadable_bag(
    capsys, tmp_path, fleet, unknown_params
):
    """A misspelt parameter file, or one that cannot be read, is argparse's error naming
    ``--params``, before any bag is read: the bag is not reported UNREADABLE, and a fleet writes
    no table of UNREADABLE rows."""
    table = tmp_path / "t.parquet"
    bags = [EXAMPLE, EXAMPLE, "-o", table] if fleet else [EXAMPLE]
    for bad in (unknown_params, tmp_path / "missing.toml"):
        status, out = _bag_tool(capsys, "check", *bags, "--params", bad)
        assert status == exit_status.EXIT_USAGE
        assert "error: argument --params: " in out, out
        assert "UNREADABLE" not in out and not table.exists()
    assert "m_wingg" in _bag_tool(capsys, "check", EXAMPLE, "--params", unknown_params)[1]


def test_check_bad_joint_names_and_force_model_are_usage_errors(capsys):
    status, out = _bag_tool(capsys, "check", EXAMPLE, "--joint-names", "a,b")
    assert status == exit_status.EXIT_USAGE and "argument --joint-names: needs 3 names" in out
    status, out = _bag_tool(capsys, "check", EXAMPLE, "--force-model", "drs_model:nothing")
    assert status == exit_status.EXIT_USAGE
    assert "argument --force-model: cannot load force model" in out


def test_check_params_the_model_refuses_say_so(capsys, tmp_path):
    path = tmp_path / "heavy.toml"
    path.write_text("m_wing = -3.0\n")
    status, out = _bag_tool(capsys, "check", EXAMPLE, "--params", path)
    assert status == exit_status.EXIT_REFUSED
    assert re.search(r"error: the model refuses --params '.*heavy\.toml': m_wing must be > 0", out)


def test_check_a_damaged_bag_is_a_bag_error(capsys, tmp_path):
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file at all")
    status, out = _bag_tool(capsys, "check", bad)
    assert status == exit_status.EXIT_UNREADABLE
    assert "drs-bag check: error: " in out and "argument" not in out


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["--set", "m_wingg=0.5"], "--set"),
        (["--set", "m_wing"], "--set"),
        (["--params", "no/such.toml"], "--params"),
    ],
)
def test_resimulate_bad_option_is_a_usage_error(capsys, argv, option):
    status, out = _bag_tool(capsys, "resimulate", EXAMPLE, *argv)
    assert status == exit_status.EXIT_USAGE
    assert f"error: argument {option}: " in out and "UNREADABLE" not in out


def test_resimulate_a_value_the_model_refuses_names_the_options(capsys):
    status, out = _bag_tool(capsys, "resimulate", EXAMPLE, "--set", "m_wing=-1")
    assert status == exit_status.EXIT_REFUSED
    want = "error: the model refuses the re-run (the recorded parameters with --params/--set)"
    assert want in out


def test_play_bad_option_is_a_usage_error(capsys):
    status, out = _bag_tool(capsys, "play", EXAMPLE, "--start-offset", "-1")
    assert status == exit_status.EXIT_USAGE
    assert "drs-bag play: error: --start-offset must be >= 0.0, got -1.0" in out


def test_a_look_ahead_consumer_that_raises_is_never_no_message():
    """The look-ahead (what finds a bag's node and its parameters) guards its reading only: an
    exception of the code that consumes its messages comes out as it is, never taken for "the
    bag has no such message" (check would fall back to the seed's parameters)."""
    require_rclpy()
    from drs_ros.bag.read import look_ahead

    assert next(look_ahead.messages(EXAMPLE, ["/parameter_events"]), None) is not None
    with pytest.raises(ValueError, match="a bug in the caller"):
        for _message in look_ahead.messages(EXAMPLE, ["/parameter_events"]):
            raise ValueError("a bug in the caller")


# ---- identification: drs-bag fit, drs-bag trend, drs excite ------------------------------------
@pytest.mark.parametrize(
    ("argv", "option", "match"),
    [
        (["--params", "m_pistt"], "--params", "'m_pistt' cannot be fitted"),
        (["--params", "Iz_pist"], "--params", "the piston does not turn"),
        (["--params", "m_pist,m_pist"], "--params", "named twice"),
        (
            ["--params", "m_pist", "--topic-map", "pressure=/p"],
            "--topic-map",
            "unknown role 'pressure'",
        ),
        (["--params", "m_pist", "--topic-map", "joint_states"], "--topic-map", "is not ROLE=TOPIC"),
        (
            ["--params", "m_pist", "--set", "L22=1"],
            "--set",
            "'L22' is no model or hydraulic parameter",
        ),
        (["--params", "m_pist", "--set", "bulk_modulus=stiff"], "--set", "is not a number"),
        (
            ["--params", "m_pist", "--noise", "stroke=-1e-5"],
            "--noise",
            "the noise of stroke must be a finite number > 0",
        ),
        (
            ["--params", "m_pist", "--noise", "strok=1e-5"],
            "--noise",
            "'strok' is no signal a re-simulation gives",
        ),
        (["--params", "m_pist", "--signals", "gap"], "--signals", "not signals a re-simulation"),
        (["--params", "m_pist", "--level", "0.3"], "--level", r"must be in \[0.5, 1\)"),
    ],
)
@pytest.mark.parametrize("fleet", [False, True])
def test_fit_bad_option_is_a_usage_error_before_any_bag_is_read(
    capsys, tmp_path, argv, option, match, fleet
):
    """The bag named does not exist: the error is the option's (argparse's line), never the
    bag's, and a season writes no table."""
    table = tmp_path / "season.parquet"
    bags = (
        [tmp_path / "no_bag", tmp_path / "no_bag2", "-o", table] if fleet else [tmp_path / "no_bag"]
    )
    status, out = _bag_tool(capsys, "fit", *bags, *argv)
    assert status == exit_status.EXIT_USAGE
    assert re.search(rf"drs-bag fit: error: argument {option}: .*{match}", out), out
    assert "no_bag" not in out.split("error:", 1)[1] and not table.exists()


def test_fit_a_bag_without_a_measurement_is_a_bag_error(capsys, tmp_path):
    status, out = _bag_tool(capsys, "fit", tmp_path / "missing", "--params", "m_pist")
    assert status == exit_status.EXIT_UNREADABLE
    assert "drs-bag fit: error: " in out and "argument" not in out and "usage" not in out


def test_fit_node_naming_no_node_of_the_bag_is_a_usage_error(capsys):
    status, out = _bag_tool(
        capsys, "fit", EXAMPLE, "--params", "m_pist", "--stage", "equation", "--node", "/nobody"
    )
    assert status == exit_status.EXIT_USAGE
    assert "drs-bag fit: error: --node '/nobody' names none of the drs nodes" in out


@pytest.fixture
def season_table(tmp_path):
    """A season of one actuator: two runs of a parameter (too few for a trend)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = tmp_path / "season.parquet"
    pq.write_table(
        pa.table(
            {
                "bag": ["a", "b"],
                "node": ["/drs", "/drs"],
                "start_ns": [0, 86_400 * 10**9],
                "leak_to_outside": [1e-13, 1e-13],
                "leak_to_outside_std": [1e-15, 1e-15],
                "leak_to_outside_determined": [True, True],
            }
        ),
        path,
    )
    return path


@pytest.mark.parametrize(
    ("argv", "option", "match"),
    [
        (["--threshold", "leak"], "--threshold", "--threshold expects NAME=VALUE"),
        (["--threshold", "leak=inf"], "--threshold", "must be finite"),
        (["--decision", "-1"], "--decision", "must be a finite number > 0"),
        (["--min-runs", "2"], "--min-runs", "must be >= 3"),
        (["--params", ","], "--params", "name at least one parameter"),
    ],
)
def test_trend_bad_option_is_a_usage_error(capsys, tmp_path, argv, option, match):
    status, out = _bag_tool(capsys, "trend", tmp_path / "no.parquet", *argv)
    assert status == exit_status.EXIT_USAGE
    assert re.search(rf"drs-bag trend: error: argument {option}: .*{match}", out), out


def test_trend_names_the_table_lacks_are_usage_errors_and_too_few_runs_a_refusal(
    capsys, tmp_path, season_table
):
    status, out = _bag_tool(capsys, "trend", season_table, "--params", "bulk_modulus")
    assert status == exit_status.EXIT_USAGE
    assert "drs-bag trend: error: --params: the table holds no fit of ['bulk_modulus']" in out
    status, out = _bag_tool(capsys, "trend", season_table, "--node", "/car7/drs_rear")
    assert status == exit_status.EXIT_USAGE and "--node '/car7/drs_rear' names none" in out
    status, out = _bag_tool(capsys, "trend", season_table, "--threshold", "m_pist=1")
    assert status == exit_status.EXIT_USAGE and "--threshold for ['m_pist']" in out
    status, out = _bag_tool(capsys, "trend", season_table)
    assert status == exit_status.EXIT_REFUSED
    assert (
        "drs-bag trend: error: the model refuses the trend: leak_to_outside: a trend needs "
        "three runs with a value, got 2"
    ) in out
    garbage = tmp_path / "garbage.parquet"
    garbage.write_bytes(b"no parquet")
    status, out = _bag_tool(capsys, "trend", garbage)
    assert status == exit_status.EXIT_UNREADABLE and "cannot read the season table" in out


@pytest.mark.parametrize(
    ("argv", "option", "match"),
    [
        (["m_pistt"], "NAME,...", "'m_pistt' cannot be fitted"),
        (["m_pist,m_pist"], "NAME,...", "named twice"),
        (["m_pist", "--duration", "-0.3"], "--duration", "must be a finite number > 0"),
        (["m_pist", "--noise", "nan"], "--noise", "must be a finite number > 0"),
        (["m_pist", "--starts", "0"], "--starts", "must be >= 1"),
        (["m_pist", "--harmonics", "two"], "--harmonics", "'two' is not an integer"),
    ],
)
def test_excite_bad_option_is_a_usage_error(capsys, argv, option, match):
    with pytest.raises(SystemExit) as exc:
        drs_main(["excite", *argv])
    assert exc.value.code == exit_status.EXIT_USAGE
    assert re.search(
        rf"drs excite: error: argument {re.escape(option)}: .*{match}", capsys.readouterr().err
    )


def test_excite_a_parameter_the_design_cannot_serve_is_the_model_s_refusal(capsys):
    assert drs_main(["excite", "m_pist,leak_to_outside"]) == exit_status.EXIT_REFUSED
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "usage" not in err
    assert "drs excite: error: " in err and "leak_to_outside depend on the pressures" in err


# ---- drs-node -----------------------------------------------------------------------------------
pytest_ros = pytest.mark.ros


@pytest_ros
def test_node_refusal_at_start_names_the_parameter(tmp_path, request):
    require_rclpy()
    res = subprocess.run(
        node_command({"model.m_wing": -2.0, "bag_path": tmp_path / "bag"}),
        env=node_env(tmp_path, domain_for(request.node.nodeid)),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == exit_status.EXIT_REFUSED, res.stderr
    assert re.search(
        r"drs-node: refused to start: the model refuses model\.m_wing:=-2\.0: "
        r"m_wing must be > 0",
        res.stderr,
    )
    assert not (tmp_path / "bag").exists()


#: ``run`` with a ``main`` that says a last line and returns 3: the process must end with 3,
#: after the exit handlers registered in Python, and nothing after ``run`` may execute.
RUN_ENDS = textwrap.dedent(
    """
    import atexit, sys
    import drs_ros.node.runner as runner

    atexit.register(lambda: print("an exit handler ran", file=sys.stderr))

    def main():
        print("main's last line", file=sys.stderr)
        return 3

    runner.main = main
    runner.run()
    print("after run", file=sys.stderr)
    """
)


def test_run_ends_the_process_with_mains_status_after_the_exit_handlers():
    """``drs-node`` ends the process itself once main returned (the middleware's teardown is
    skipped): main's status, its last lines, the exit handlers, nothing after."""
    res = subprocess.run(
        [sys.executable, "-c", RUN_ENDS], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 3, res.stderr
    assert res.stderr.splitlines()[-2:] == ["main's last line", "an exit handler ran"]


#: A node whose run ends with a model error after its first tick (as a failure escaping the
#: loop would): it must not say it refused to start, and it finishes its recordings.
FAILING_RUN = textwrap.dedent(
    """
    import sys
    from drs_model.errors import ConvergenceError
    import drs_ros.node.runner as runner

    def failing_loop(node, stop, context=None):
        node.tick()
        raise ConvergenceError("the model gave up while running")

    runner.run_deadline_loop = failing_loop
    sys.exit(runner.main(["drs-node", "--ros-args", "-p", "bag_path:=" + sys.argv[1]]))
    """
)


@pytest_ros
def test_node_error_while_running_is_not_a_refusal_to_start(tmp_path, request):
    require_rclpy()
    bag = tmp_path / "bag"
    res = subprocess.run(
        [sys.executable, "-c", FAILING_RUN, str(bag)],
        env=node_env(tmp_path, domain_for(request.node.nodeid)),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == exit_status.EXIT_INTERNAL, res.stderr
    assert "refused to start" not in res.stderr
    assert (
        "drs-node: stopped by an error while running: ConvergenceError: the model gave up "
        "while running"
    ) in res.stderr
    assert (bag / "metadata.yaml").exists()  # the recordings were finished
