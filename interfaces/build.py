"""Build the ROS 2 interface packages that no PyPI wheel ships into this venv.

``tf2_msgs`` (TFMessage) and ``control_msgs`` (FollowJointTrajectory and its tolerance messages)
are built here from their upstream Jazzy definitions (``interfaces/<pkg>/``, byte for byte, so
the type names and RIHS01 hashes are upstream's) with the ROS 2 build tools from PyPI
(``interfaces/build-requirements.txt``: ament_cmake, rosidl generators), CMake and a C/C++
compiler, exactly as a ROS workspace builds them: ``rosidl_generate_interfaces`` in each
package's ``CMakeLists.txt``, configure, build, install.

They are installed into the venv's prefix, where the wheels put theirs: Python code in
``site-packages/<pkg>``, libraries in ``lib/`` (which the wheels' start-up hook puts on
``LD_LIBRARY_PATH``), ``share/<pkg>/msg/*.msg`` and ``*.json`` (type descriptions with the
hashes, read by :mod:`drs_ros.recording.msgdefs`) and the ament index. Build trees stay in
``build/``.
Nothing outside the venv and the build directory is written; the wheels' installed files are not
edited (``interfaces/wheel_targets.cmake`` corrects their foreign include paths in the build's
memory only).

Run by ``make venv`` (and so by ``make demo`` and ``make test``)::

    .venv/bin/python interfaces/build.py            # prints the packages, hashes and the time

Exit status 0 when every package is built, installed and imports; 2 with one line on stderr
otherwise.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: The packages, in build order, and one type of each that must import afterwards.
PACKAGES = {
    "tf2_msgs": "tf2_msgs.msg.TFMessage",
    "control_msgs": "control_msgs.action.FollowJointTrajectory",
}


class BuildError(RuntimeError):
    """A step of the build failed (the message says which, and where its log is)."""


def venv_prefix() -> Path:
    """This interpreter's venv: the build never installs into a Python it does not own."""
    if sys.prefix == sys.base_prefix:
        raise BuildError(
            f"{sys.executable} is not a venv's interpreter: run this with the project's venv "
            "(.venv/bin/python interfaces/build.py), never into a system Python"
        )
    return Path(sys.prefix)


def check_tools(prefix: Path) -> None:
    missing = [
        pkg
        for pkg in (
            "ament_cmake",
            "rosidl_default_generators",
            "rosidl_core_generators",
            "ament_cmake_ros",
            "ament_cmake_include_directories",
        )
        if not (prefix / "share" / pkg).is_dir()
    ]
    if missing:
        raise BuildError(
            f"ROS build tools missing from {prefix}: {', '.join(missing)}; install them with "
            f"{prefix}/bin/python -m pip install -r {HERE / 'build-requirements.txt'}"
        )
    for tool in ("cmake", "cc", "c++"):
        if shutil.which(tool) is None:
            raise BuildError(
                f"{tool} not found on PATH: building interfaces needs CMake and a C/C++ compiler "
                "(Debian: apt-get install cmake build-essential)"
            )


def run(cmd: list[str], env: dict[str, str], log: Path) -> None:
    with log.open("w") as out:
        proc = subprocess.run(cmd, env=env, stdout=out, stderr=subprocess.STDOUT)
    if proc.returncode != 0:
        tail = log.read_text(errors="replace").splitlines()[-15:]
        raise BuildError(
            f"{' '.join(cmd[:3])}... failed (exit {proc.returncode}); log {log}:\n"
            + "\n".join(tail)
        )


def build_package(name: str, prefix: Path, build_root: Path, env: dict[str, str]) -> None:
    import numpy

    source, build = HERE / name, build_root / name
    build.mkdir(parents=True, exist_ok=True)
    generator = ["-G", "Ninja"] if shutil.which("ninja") else []
    configure = [
        "cmake",
        "-S",
        str(source),
        "-B",
        str(build),
        *generator,
        f"-DCMAKE_INSTALL_PREFIX={prefix}",
        f"-DCMAKE_PREFIX_PATH={prefix}",
        "-DCMAKE_BUILD_TYPE=Release",
        "-DBUILD_TESTING=OFF",
        f"-DPython3_EXECUTABLE={sys.executable}",
        f"-DCMAKE_PROJECT_INCLUDE={HERE / 'wheel_targets.cmake'}",
        f"-DDRS_PYTHON_INCLUDE_DIR={sysconfig.get_paths()['include']}",
        f"-DDRS_NUMPY_INCLUDE_DIR={numpy.get_include()}",
    ]
    run(configure, env, build / "drs-configure.log")
    run(["cmake", "--build", str(build)], env, build / "drs-build.log")
    run(["cmake", "--install", str(build)], env, build / "drs-install.log")


def check_installed(prefix: Path, env: dict[str, str]) -> dict[str, str]:
    """Import each package's type in a fresh interpreter; return type name -> RIHS01 hash."""
    code = "import importlib, sys\nfor path in sys.argv[1:]:\n    mod, _, cls = path.rpartition('.')\n    getattr(importlib.import_module(mod), cls)\n"  # noqa: E501
    proc = subprocess.run(
        [sys.executable, "-c", code, *PACKAGES.values()], env=env, capture_output=True, text=True
    )
    if proc.returncode != 0:
        raise BuildError(f"the built interfaces do not import: {proc.stderr.strip()[-800:]}")
    hashes = {}
    for name in PACKAGES:
        for path in sorted((prefix / "share" / name).glob("*/*.json")):
            for entry in json.loads(path.read_text())["type_hashes"]:
                if entry["type_name"].count("/") == 2 and entry["type_name"].startswith(name):
                    hashes[entry["type_name"]] = entry["hash_string"]
    return hashes


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--build-dir",
        default=str(HERE.parent / "build" / "interfaces"),
        help="where the CMake build trees go (default: build/interfaces)",
    )
    parser.add_argument("--quiet", action="store_true", help="print only the summary line")
    args = parser.parse_args(argv)
    start = time.monotonic()
    try:
        prefix = venv_prefix()
        check_tools(prefix)
        env = {**os.environ, "AMENT_PREFIX_PATH": str(prefix), "CMAKE_PREFIX_PATH": str(prefix)}
        for name in PACKAGES:
            t = time.monotonic()
            build_package(name, prefix, Path(args.build_dir), env)
            if not args.quiet:
                print(
                    f"interfaces: {name} built and installed into {prefix} "
                    f"({time.monotonic() - t:.1f} s)"
                )
        hashes = check_installed(prefix, env)
    except BuildError as exc:
        print(f"interfaces/build.py: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        for type_name, value in sorted(hashes.items()):
            print(f"  {type_name:50s} {value}")
    print(f"interfaces: {', '.join(PACKAGES)} ready in {time.monotonic() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
