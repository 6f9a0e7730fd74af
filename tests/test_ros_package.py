"""The ROS package: package.xml is a valid format-3 manifest that declares what the code imports,
and colcon's ament_python build of a scratch workspace installs the ament index marker, the
manifest and the console scripts where ``ros2 run``/``ros2 pkg`` look, and ``drs-node`` starts
from that install space."""

from __future__ import annotations

import ast
import os
import shutil
import signal
import stat
import subprocess
import sys
import time
import tomllib
import zipfile
from pathlib import Path

import pytest
from node_support import domain_for, node_env, wait_for_file_growth
from ros_support import require_module, require_rclpy

from drs_ros.node.command_line import node_command

REPO = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]

#: ROS packages the node needs at run time; each must be an exec_depend.
ROS_DEPENDENCIES = {
    "rclpy",
    "sensor_msgs",
    "std_msgs",
    "std_srvs",
    "diagnostic_msgs",
    "trajectory_msgs",
    "geometry_msgs",
    "rosgraph_msgs",
    "visualization_msgs",
    "lifecycle_msgs",
    "rcl_interfaces",
    "service_msgs",
    "builtin_interfaces",
    "tf2_msgs",
    "control_msgs",
    "action_msgs",
}
#: rosdep keys of the PyPI dependencies that have one.
ROSDEP_KEYS = {"numpy": "python3-numpy", "scipy": "python3-scipy", "pyyaml": "python3-yaml"}
#: What the copy of the repository in a scratch workspace leaves out (not part of the build).
NOT_SOURCE = shutil.ignore_patterns(
    ".git",
    ".venv",
    "bags",
    "build",
    "install",
    "log",
    "__pycache__",
    "*.egg-info",
    ".pytest_cache",
    ".ruff_cache",
    ".hypothesis",
    ".ros-log",
    "out",
)


def parse_manifest():
    catkin_pkg_package = require_module("catkin_pkg.package")
    return catkin_pkg_package.parse_package(str(REPO / "package.xml"))


def requirement_name(req: str) -> str:
    return req.split(";")[0].split("[")[0].split("<")[0].split(">")[0].split("=")[0].strip().lower()


def imported_ros_packages() -> set[str]:
    """Top-level names of ROS packages imported anywhere in ``drs_ros`` (read from the source)."""
    found = set()
    for path in (REPO / "drs_ros").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top == "rclpy" or top.endswith(("_msgs", "_srvs", "_interfaces")):
                    found.add(top)
    return found


def test_package_xml_is_valid_format3():
    pkg = parse_manifest()
    pkg.validate()  # raises InvalidPackage on any violation of REP 149 (format 3)
    assert pkg.package_format == 3
    assert pkg.name == PYPROJECT["name"]
    assert pkg.version == PYPROJECT["version"]
    assert [lic for lic in pkg.licenses] == [PYPROJECT["license"]]
    assert pkg.get_build_type() == "ament_python"
    assert [d.name for d in pkg.buildtool_depends] == ["ament_python"]


def test_package_xml_declares_what_the_code_imports():
    pkg = parse_manifest()
    exec_depends = {d.name for d in pkg.exec_depends}
    imported = imported_ros_packages()
    assert imported, "no ROS import found in drs_ros: the scan is broken"
    assert imported <= exec_depends, f"imported but not declared: {imported - exec_depends}"
    assert ROS_DEPENDENCIES <= exec_depends, ROS_DEPENDENCIES - exec_depends
    python_deps = {requirement_name(r) for r in PYPROJECT["dependencies"]}
    python_deps |= {requirement_name(r) for r in PYPROJECT["optional-dependencies"]["ros"]}
    for dist, key in ROSDEP_KEYS.items():
        assert dist in python_deps, f"{dist} is no longer a dependency: drop {key}"
        assert key in exec_depends, f"{dist} is a dependency but {key} is not an exec_depend"
    assert {"python3-pytest", "python3-hypothesis"} <= {d.name for d in pkg.test_depends}


def test_wheel_installs_the_ament_index_marker_and_the_manifest(tmp_path):
    """The same setup as colcon's, through pip: data files, console scripts, Requires-Python."""
    require_module("setuptools")
    src = tmp_path / "drs"
    shutil.copytree(REPO, src, ignore=NOT_SOURCE)
    env = {**os.environ, "PIP_NO_INDEX": "1"}
    cmd = [
        sys.executable,
        "-m",
        "pip",
        "wheel",
        "--no-deps",
        "--no-build-isolation",
        "-q",
        "-w",
        str(tmp_path / "dist"),
        str(src),
    ]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (wheel,) = (tmp_path / "dist").glob("drs-*.whl")
    data = f"drs-{PYPROJECT['version']}.data/data/"
    with zipfile.ZipFile(wheel) as zf:
        names = set(zf.namelist())
        assert data + "share/ament_index/resource_index/packages/drs" in names
        assert zf.read(data + "share/drs/package.xml") == (REPO / "package.xml").read_bytes()
        for cfg in (REPO / "config").glob("*"):
            assert data + f"share/drs/config/{cfg.name}" in names
        info = f"drs-{PYPROJECT['version']}.dist-info/"
        entry_points = zf.read(info + "entry_points.txt").decode()
        metadata = zf.read(info + "METADATA").decode()
    for script, target in PYPROJECT["scripts"].items():
        assert f"{script} = {target}" in entry_points
    assert (
        "Requires-Python: <3.12,>=3.11" in metadata or "Requires-Python: >=3.11,<3.12" in metadata
    )


def setup_sh_environment(ws: Path, base: dict[str, str]) -> dict[str, str]:
    """The environment after ``. install/setup.sh`` in ``ws`` (what a user does), from ``base``."""
    proc = subprocess.run(
        ["sh", "-c", ". ./install/setup.sh && env -0"],
        cwd=ws,
        env=base,
        capture_output=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    pairs = (item.split("=", 1) for item in proc.stdout.decode().split("\0") if "=" in item)
    return dict(pairs)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize("symlink_install", [False, True], ids=["install", "symlink-install"])
def test_colcon_build_then_drs_node_from_the_install_space(tmp_path, request, symlink_install):
    for module in ("colcon_core", "colcon_ros", "colcon_python_setup_py", "catkin_pkg"):
        require_module(module)
    require_rclpy()
    ament_index = require_module("ament_index_python.packages")
    ws = tmp_path / "ws"
    shutil.copytree(REPO, ws / "src" / "drs", ignore=NOT_SOURCE)
    colcon = [
        sys.executable,
        "-c",
        "import sys; from colcon_core.command import main; sys.exit(main())",
    ]
    build = [*colcon, "build", "--base-paths", "src", "--event-handlers", "console_direct+"]
    if symlink_install:
        build.append("--symlink-install")
    env = {**os.environ, "COLCON_HOME": str(tmp_path / "colcon-home")}
    proc = subprocess.run(build, cwd=ws, env=env, capture_output=True, text=True, timeout=600)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert "Finished <<< drs" in out, out
    # colcon-ros installs a marker and the manifest itself (with this warning) when the package
    # does not: ours must come from the package's own data files.
    assert "doesn't explicitly install" not in out, out

    prefix = ws / "install" / "drs"
    marker = prefix / "share/ament_index/resource_index/packages/drs"
    assert marker.is_file()
    share = prefix / "share" / "drs"
    assert (share / "package.xml").read_bytes() == (REPO / "package.xml").read_bytes()
    for cfg in (REPO / "config").glob("*"):
        assert (share / "config" / cfg.name).read_bytes() == cfg.read_bytes()
    lib = prefix / "lib" / "drs"  # where `ros2 run drs <script>` looks
    for script in PYPROJECT["scripts"]:
        mode = (lib / script).stat().st_mode
        assert mode & stat.S_IXUSR, f"{lib / script} is not executable"
    assert (lib / "drs-node").read_text().splitlines()[0] == f"#!{sys.executable}"

    # What `ros2 pkg prefix drs` resolves through the ament index.
    old = os.environ.get("AMENT_PREFIX_PATH")
    os.environ["AMENT_PREFIX_PATH"] = str(prefix)
    try:
        assert Path(ament_index.get_package_prefix("drs")) == prefix
        assert Path(ament_index.get_package_share_directory("drs")) == share
    finally:
        if old is None:
            del os.environ["AMENT_PREFIX_PATH"]
        else:
            os.environ["AMENT_PREFIX_PATH"] = old

    # The install space's environment, without the checkout on PYTHONPATH: drs comes from the
    # workspace (install/, or build/ linking to src/ with --symlink-install), not from the venv.
    base = node_env(tmp_path, domain_for(request.node.nodeid))
    base.pop("PYTHONPATH", None)
    run_env = setup_sh_environment(ws, base)
    assert str(prefix) in run_env["AMENT_PREFIX_PATH"].split(os.pathsep)
    where = subprocess.run(
        [
            sys.executable,
            "-c",
            "import drs_ros.node, drs_model; print(drs_ros.node.__file__); "
            "print(drs_model.__file__)",
        ],
        cwd=lib,
        env=run_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert where.returncode == 0, where.stderr
    files = [Path(f) for f in where.stdout.split()]
    assert len(files) == 2 and all(f.resolve().is_relative_to(ws) for f in files), where.stdout

    bag, rrd = tmp_path / "bag", tmp_path / "run.rrd"
    node = subprocess.Popen(
        node_command(
            {"bag_path": bag, "rrd_path": rrd, "flush_period": 0.2}, program=[str(lib / "drs-node")]
        ),
        cwd=tmp_path,
        env=run_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        mcap = bag / "bag_0.mcap"
        grew = wait_for_file_growth(mcap, timeout=30.0, min_size=2000)
        # the first flush already holds the robot description (~30 kB): wait for a later one
        grew = grew and wait_for_file_growth(
            mcap, timeout=30.0, min_size=mcap.stat().st_size + 2000
        )
        # let it tick after that flush, as the clean-exit tests do
        time.sleep(1.0)
        node.send_signal(signal.SIGINT)
        node_out, _ = node.communicate(timeout=30)
    finally:
        if node.poll() is None:
            node.kill()
            node.communicate()
    assert grew, node_out
    assert node.returncode == 0, node_out
    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as reader:
        joint_states = [c for c in reader.connections if c.topic == "/joint_states"]
        n = sum(1 for _ in reader.messages(connections=joint_states))
    assert n > 10
    assert rrd.is_file() and rrd.stat().st_size > 1000
