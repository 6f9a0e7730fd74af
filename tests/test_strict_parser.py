"""Every console script takes whole option names only: a prefix (``--jso`` for ``--json``) is
refused with exit status 2 and the option named, as an unknown option is."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from drs_model.cli.strict_parser import StrictParser

BIN = Path(sys.executable).parent
EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"


def test_a_prefix_of_an_option_is_not_taken_for_it():
    parser = StrictParser(prog="t")
    parser.add_argument("--stroke", type=float)
    sub = parser.add_subparsers(dest="verb")
    sub.add_parser("go").add_argument("--json", action="store_true")
    assert parser.parse_args(["--stroke", "0.01"]).stroke == 0.01
    with pytest.raises(SystemExit) as refused:
        parser.parse_args(["--strok", "0.01"])
    assert refused.value.code == 2
    with pytest.raises(SystemExit):  # the verbs' parsers are of the same class
        parser.parse_args(["go", "--jso"])
    # the plain argparse parser would have taken both: what this class exists for
    plain = argparse_parser()
    assert plain.parse_args(["--strok", "0.01"]).stroke == 0.01


def argparse_parser():
    import argparse

    plain = argparse.ArgumentParser(prog="t")
    plain.add_argument("--stroke", type=float)
    return plain


@pytest.mark.parametrize(
    "argv, option",
    [
        (["drs", "limits", "--jso"], "--jso"),
        (["drs-bag", "check", str(EXAMPLE), "--jso"], "--jso"),
        (["drs-bag", "play", str(EXAMPLE), "--cloc"], "--cloc"),
        (["drs-demo", "--ou", "/nonexistent/x"], "--ou"),
    ],
)
def test_each_console_script_refuses_a_prefix(argv, option):
    proc = subprocess.run(
        [str(BIN / argv[0]), *argv[1:]], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert option in proc.stderr and "Traceback" not in proc.stderr
