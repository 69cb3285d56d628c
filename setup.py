"""Build hook: ship the example recordings, scenes and fit recipes inside the package.

The repository's ``datasets/`` and ``fits/`` trees are copied into the built package as
``escfit/_examples/datasets`` and ``escfit/_examples/fits`` (their layout kept, so that the
recipes' relative paths still work), for ``escfit examples DIR`` to copy out of an installed
wheel.  Caches and compiled files are left out.  An editable install reads the trees of the
source checkout instead.  Everything else is configured in ``pyproject.toml``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
EXAMPLE_TREES = ("datasets", "fits")
SKIP = shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo", ".ipynb_checkpoints", "*.part", ".DS_Store")


class BuildPyWithExamples(build_py):
    """``build_py`` that also copies the example trees into ``escfit/_examples``."""

    def run(self):
        super().run()
        if self.editable_mode:  # the source checkout's trees are read in place
            return
        target = Path(self.build_lib) / "escfit" / "_examples"
        for name in EXAMPLE_TREES:
            source = HERE / name
            if not source.is_dir():  # an sdist made without them: the wheel ships no examples
                self.warn(f"{source} not found; the package will have no {name} examples")
                continue
            if (target / name).exists():
                shutil.rmtree(target / name)
            shutil.copytree(source, target / name, ignore=SKIP)


setup(cmdclass={"build_py": BuildPyWithExamples})
