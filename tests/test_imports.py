"""The package structure: nothing in drs_model or drs_ros imports in a circle, and each module
imports alone (first, in a process where no module of drs was imported: tests/import_alone.py).

The graph is read from the source with ``ast`` (every ``import`` and ``from ... import``, at module
level or inside a function: an import inside a function is how a cycle hides), so the test sees
what the code says, not what a warm interpreter happens to have loaded.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import layout
import pytest
from ros_support import require_rclpy

ROOT = layout.ROOT
#: The modules of drs_model and drs_ros and the graph of their imports, read by tests/layout.py.
MODULES = layout.modules()
GRAPH = layout.graph()


def test_the_graph_is_read():
    assert "drs_model.kernels" in GRAPH["drs_model.kinematics"]
    assert "drs_model.compiled.simulate" in GRAPH["drs_model.forward.solve"]
    assert GRAPH["drs_model.kernels"] == set()  # the bottom of the stack
    assert "drs_ros.recording.cdr" in GRAPH["drs_ros.node.adapter"]
    assert "drs_model.fidelity" in GRAPH["drs_ros.node.rung_choice"]  # the node's rungs
    assert "drs_model.actuator" in GRAPH["drs_model.fidelity.rigid"]


def test_no_import_cycle():
    """Depth-first search for a back edge; a module importing its own parent package's
    ``__init__`` (re-exports) is not counted."""
    cycle = layout.first_cycle(GRAPH)
    if cycle:
        pytest.fail("import cycle: " + " -> ".join(cycle))


#: Modules that import numba (the optional extra ``fast``) when they are imported.
NEEDS_NUMBA = ("drs_model.compiled.",)


@pytest.fixture(scope="module")
def import_alone():
    """A process (tests/import_alone.py) that imports each module it is sent in a fork of its own,
    taken before any module of drs was imported; one per test module and worker."""
    import json

    server = subprocess.Popen(
        [sys.executable, str(Path(__file__).with_name("import_alone.py"))],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    # the children fork from a process where no module of drs was imported
    assert json.loads(server.stdout.readline()) == {"ready": True, "drs_modules_loaded": []}

    def import_alone(name: str) -> dict:
        server.stdin.write(name + "\n")
        server.stdin.flush()
        return json.loads(server.stdout.readline())

    yield import_alone
    server.stdin.close()
    assert server.wait(timeout=60) == 0


@pytest.mark.parametrize("name", sorted(n for n in MODULES if not n.endswith("__main__")))
def test_each_module_imports_alone(name, import_alone):
    if name.startswith(NEEDS_NUMBA) and importlib.util.find_spec("numba") is None:
        if not os.environ.get("CI"):
            pytest.skip("numba is not installed (pip install drs[fast])")
    if name.startswith("drs_ros"):
        require_rclpy()
    result = import_alone(name)
    assert (result["name"], result["status"]) == (name, 0), result["error"]


def test_a_module_that_cannot_import_alone_is_reported(import_alone):
    """A module of drs whose import fails gives its status and traceback (so a pass means
    something): ``drs_model`` cannot be imported under a name it does not have."""
    result = import_alone("drs_model.no_such_module")
    assert result["status"] == 1
    assert "ModuleNotFoundError: No module named 'drs_model.no_such_module'" in result["error"]


def test_a_cycle_would_be_found(monkeypatch):
    """The search fails on a planted cycle (so a pass means something)."""
    planted = {k: set(v) for k, v in GRAPH.items()}
    planted["drs_model.kernels"].add("drs_model.params")
    monkeypatch.setattr(sys.modules[__name__], "GRAPH", planted)
    with pytest.raises(pytest.fail.Exception, match="import cycle: .*drs_model.kernels"):
        test_no_import_cycle()


#: What drs_model never imports: it is the model, and ROS adapts it (drs_ros), not the other way.
ROS_ONLY = ("drs_ros", "rclpy")


def _ros_imports(path: Path) -> list[str]:
    """``file:line name`` of every import of :data:`ROS_ONLY` in ``path``, at any depth (inside a
    function, a ``try``, a branch), including ``importlib.import_module("...")`` and
    ``__import__("...")`` of a literal name."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [node.module or ""]
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if called in ("import_module", "__import__") and isinstance(node.args[0].value, str):
                names = [node.args[0].value]
        found += [
            f"{path.relative_to(ROOT)}:{node.lineno} {n}"
            for n in names
            if n.split(".")[0] in ROS_ONLY
        ]
    return found


def test_drs_model_never_imports_drs_ros_or_rclpy():
    files = sorted((ROOT / "drs_model").rglob("*.py"))
    assert len(files) > 50
    assert [hit for path in files for hit in _ros_imports(path)] == []


def test_a_ros_import_in_drs_model_would_be_found(tmp_path, monkeypatch):
    """Imports hidden inside a function, as a relative-looking name, or by importlib, are found
    (so a pass means something)."""
    planted = tmp_path / "drs_model" / "planted.py"
    planted.parent.mkdir()
    planted.write_text(
        "import importlib\n"
        "def f():\n"
        "    try:\n"
        "        from drs_ros.bag.from_goal import write_goal_bag\n"
        "    except ImportError:\n"
        "        import rclpy.node\n"
        "    return importlib.import_module('drs_ros.names')\n"
    )
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert sorted(h.split(" ", 1)[1] for h in _ros_imports(planted)) == [
        "drs_ros.bag.from_goal",
        "drs_ros.names",
        "rclpy.node",
    ]
