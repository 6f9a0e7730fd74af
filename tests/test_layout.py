"""The code keeps the shape a newcomer can live in (tests/layout.py measures it): no function of
drs_model or drs_ros over 80 lines, no module over 500, and no line of the product's code, tests,
docs or benchmarks that speaks of the work that built it (an issue by number, its rounds, its
sittings and workers, the builds of the past) instead of the product; and a README whose
layout table names every module; the tree as ``ruff format`` writes it, with at most
five ``# fmt: skip``. Each check is also run on a planted case, so a pass means
something."""

from __future__ import annotations

import layout


def test_no_function_over_the_limit():
    assert layout.long_functions() == []


def test_no_module_over_the_limit():
    assert layout.long_modules() == []


def test_the_product_speaks_of_the_product():
    assert layout.process_words() == []


def test_the_tree_is_formatted():
    assert layout.unformatted() == []


def test_a_table_that_reads_better_aligned_is_the_only_fmt_skip():
    skips = layout.format_skips()
    assert len(skips) <= layout.FMT_SKIP_LIMIT, skips


def test_an_unformatted_file_and_a_skip_would_be_found(tmp_path):
    root = _planted(tmp_path, "x = [1,2 ,3]  # fmt: skip\ny = {'a':1}\n")
    assert layout.unformatted(root) == ["drs_model/planted.py"]
    assert layout.format_skips(root) == ["drs_model/planted.py:1"]
    (root / "drs_model" / "planted.py").write_text('y = {"a": 1}\n')
    assert layout.unformatted(root) == []
    assert layout.format_skips(root) == []


def test_the_readme_names_every_module():
    assert layout.unlisted_modules() == []


def test_an_unlisted_module_would_be_found(tmp_path):
    root = _planted(tmp_path, "x = 1\n")
    (root / "README.md").write_text("| `drs_model/` | the model: `other` |\n")
    assert layout.unlisted_modules(root) == ["drs_model.planted"]
    (root / "README.md").write_text("| `drs_model/` | the model: `planted` |\n")
    assert layout.unlisted_modules(root) == []


def _planted(tmp_path, body: str):
    pkg = tmp_path / "drs_model"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "planted.py").write_text(body)
    (tmp_path / "drs_ros").mkdir()
    return tmp_path


def test_a_long_function_and_module_would_be_found(tmp_path):
    body = "def f():\n" + "    x = 1\n" * 90 + "\n\ndef g():\n    return 2\n" + "# pad\n" * 420
    root = _planted(tmp_path, body)
    assert layout.long_functions(root=root) == [("drs_model/planted.py", 1, "f", 91)]
    assert layout.long_functions(limit=91, root=root) == []
    assert layout.long_modules(root=root) == [("drs_model.planted", 515)]


def test_process_words_would_be_found(tmp_path):
    said = [
        "# the fix of iss" + "ue 17",
        "x = 1  # as before iss" + "ue",
        "see the sess" + "ion of 2026-11-23",
        "today's " + "model takes it",
        "a test sess" + "ion warms the cache",
    ]
    kept = [
        "ros2/rosbag2#2365 (upstream)",
        "@pytest.fixture(scope='session')",
        "the issues an engineer files",
    ]
    root = _planted(tmp_path, "\n".join(said + kept) + "\n")
    found = layout.process_words(root)
    assert [f.split(": ", 1)[1] for f in found] == said


#: Lines that tell the project's history, one per place the check reads, each with where it is
#: planted; and lines of the product that use the same words for what the product does.
HISTORY = {
    "docs/ros.md": "**Rate, third " + "pass** (the same commands on a quiet machine)",
    "README.md": "measured against the build before this " + "pass",
    "benchmarks/results/node_rate.md": "on a machine shared with three other ag" + "ents",
    "docs/scale.md": "The machine is shared with other sess" + "ions: its load",
    "drs_ros/bag/planted.py": "# a re-run: older " + "builds ran the fused path",
    "drs_model/planted.py": "# as in earlier " + "builds",
    "tests/test_planted.py": "# see the composition " + "pass",
    "docs/layout.md": "## The Second " + "Pass: one copy of what was left",
    "docs/forward.md": "Not taken in that " + "pass; the ag" + "ent moved on",
}
PRODUCT = [
    '@pytest.fixture(scope="session")',
    "# second solve with the noise estimated",
    "one compiled pass over the times",
    "the relief passes what the valve gives",
    "a bag recorded before the effect record existed",
    "the bag passes `check`",
    "each pass of the sweep",
    "a build of the driver per method",
]


def test_history_would_be_found_in_every_place(tmp_path):
    root = _planted(tmp_path, "")
    for place, line in HISTORY.items():
        path = root / place
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(PRODUCT + [line]) + "\n")
    found = sorted(f.split(":", 1)[0] for f in layout.process_words(root))
    assert found == sorted(HISTORY)
    for place in HISTORY:
        (root / place).write_text("\n".join(PRODUCT) + "\n")
    assert layout.process_words(root) == []


def test_a_cycle_would_be_found():
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "a.x": {"a"}}
    assert layout.first_cycle(g) == ["a", "b", "c", "a"]
    assert layout.first_cycle({"a": set(), "a.x": {"a"}, "b": {"a.x"}}) is None
