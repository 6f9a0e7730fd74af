"""For colcon's ``ament_python`` build type, which runs ``setup.py``.

Every piece of metadata but one lives in ``pyproject.toml`` (name, version, dependencies, console
scripts, and the ament index marker, ``package.xml`` and ``config/`` as data files). The
exception is ``python_requires``: colcon reads this file's metadata with ``ast.literal_eval``,
which cannot read the ``SpecifierSet`` that setuptools makes of a static ``requires-python``
(colcon/colcon-python-setup-py#56), so it is declared dynamic there and given here as a string.

``colcon build --symlink-install`` runs ``setup.py develop`` in a build directory that holds links
to this file, ``setup.cfg``, the packages and the data files only: the links to
``pyproject.toml`` and the readme it names are made here, so that setuptools finds the metadata.
"""

from pathlib import Path

from setuptools import setup

SOURCE = Path(__file__).resolve().parent
for name in ("pyproject.toml", "README.md"):
    if not Path(name).exists():
        Path(name).symlink_to(SOURCE / name)

setup(python_requires=">=3.11,<3.12")
