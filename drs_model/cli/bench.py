"""``drs bench``: the forward-dynamics work-precision benchmark (benchmarks/work_precision.py)."""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

from ..errors import InputError
from ._common import Output


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bench",
        help="work-precision benchmark of the forward dynamics (source checkout only)",
        description="Every formulation x integrator x tolerance on the seed manoeuvre against the "
        "sympy baseline; writes benchmarks/results/work_precision.json and "
        "docs/img/work_precision.png. About 5 minutes (--quick: ~30 s).",
    )
    p.add_argument("--json", action="store_true", help="print machine-readable JSON")
    p.add_argument("--quick", action="store_true", help="a ~30 s subset")
    p.add_argument("--repeats", type=int, default=None, help="timing repeats (median)")
    p.add_argument("--no-write", action="store_true", help="do not write the JSON and the chart")
    p.set_defaults(func=run_bench)


def _load_benchmark():
    root = Path(__file__).resolve().parents[2]
    path = root / "benchmarks" / "work_precision.py"
    if not path.is_file():
        raise InputError(f"the benchmark needs a source checkout: {path} not found")
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    spec = importlib.util.spec_from_file_location("benchmarks.work_precision", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_bench(args) -> Output:
    wp = _load_benchmark()
    kwargs = {"quick": args.quick, "repeats": args.repeats, "log": lambda *a: None}
    if args.no_write:
        kwargs.update(json_path=None, png_path=None)
    results = wp.run(**kwargs)
    return Output(wp._clean(results), wp.report(results))
