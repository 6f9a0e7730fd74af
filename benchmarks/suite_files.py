"""Where the test suite's time goes, file by file: reads the output of
``python -m pytest --durations=0 -vv`` (every setup, call and teardown with its seconds) and prints
a Markdown table of the seconds of each test file (setup + call + teardown of its tests), the
slowest first; with two outputs, a column for each (before, after). pytest hides the phases under
5 ms unless ``-vv``: at most a few seconds in all.

Under pytest-xdist the seconds are those of the worker that ran the test, beside the other worker:
their sum is worker time, not wall time (the run's last line gives that).

Usage: ``python benchmarks/suite_files.py DURATIONS.txt [AFTER.txt] [--top 30]``
"""

from __future__ import annotations

import argparse
import re
import sys
from collections import Counter
from pathlib import Path

#: One line of ``--durations``: seconds, phase, test id.
DURATION = re.compile(r"^\s*([\d.]+)s (setup|call|teardown)\s+(\S+)")
#: pytest's last line: ``N passed, M failed ... in S s``.
SUMMARY = re.compile(r"^=*\s*(\d+ (?:passed|failed|error).*?) in ([\d.]+)s")


def per_file(text: str) -> tuple[Counter, str]:
    """``(seconds, summary)``: the seconds [s] of each test file and pytest's summary line."""
    seconds: Counter = Counter()
    summary = ""
    for line in text.splitlines():
        if m := DURATION.match(line):
            seconds[m[3].split("::")[0]] += float(m[1])
        elif m := SUMMARY.search(line):
            summary = f"{m[1]} in {float(m[2]):.0f} s"
    return seconds, summary


def table(runs: list[tuple[Counter, str]], top: int) -> str:
    """The Markdown table of the ``top`` slowest files of the first run, the rest summed."""
    first = runs[0][0]
    names = sorted(set().union(*(r[0] for r in runs)), key=lambda f: -first.get(f, 0.0))
    rows = ["| file | " + " | ".join(f"run {k + 1} [s]" for k in range(len(runs))) + " |"]
    rows.append("|---|" + "---:|" * len(runs))
    for name in names[:top]:
        cells = " | ".join(f"{seconds.get(name, 0.0):.1f}" for seconds, _ in runs)
        rows.append(f"| `{Path(name).name}` | {cells} |")
    rest = [sum(v for k, v in seconds.items() if k not in names[:top]) for seconds, _ in runs]
    cells = " | ".join(f"{x:.1f}" for x in rest)
    rows.append(f"| the other {max(len(names) - top, 0)} files | {cells} |")
    cells = " | ".join(f"{sum(seconds.values()):.0f}" for seconds, _ in runs)
    rows.append(f"| **sum** | {cells} |")
    rows += [f"\nrun {k + 1}: {summary}" for k, (_, summary) in enumerate(runs)]
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outputs", nargs="+", type=Path, help="pytest --durations=0 outputs")
    ap.add_argument("--top", type=int, default=30, help="files listed (the rest summed)")
    args = ap.parse_args(argv)
    runs = [per_file(p.read_text(errors="replace")) for p in args.outputs]
    print(table(runs, args.top))
    return 0


if __name__ == "__main__":
    sys.exit(main())
