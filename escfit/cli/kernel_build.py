"""Compile the kernels shipped with escfit (:mod:`escfit.core.kernel_store`) afresh.

Run from a checkout after changing a kernel or a module compiled into one::

    python -m escfit.cli.kernel_build

A child process with an empty numba cache, numba's generic x86-64 processor
(``NUMBA_CPU_NAME=generic``) and the store turned off runs :data:`WORKLOADS` (what a newcomer
runs first: the README's two examples, the string pendulum's least squares, a starter scene,
and a short posterior run of the first example for the whole-ensemble dop853 sampler)
and stores every kernel it compiled; ``escfit/_kernels`` is then replaced with the result.
About a minute on two cores.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ..core.kernel_store import GENERIC, STORE, save_all
from ..core.kernels import compiled_kernels

__all__ = ["WORKLOADS", "build"]

WORKLOADS = (
    ["fit", "fits/real/encoder_pendulum_jensen.toml", "--out", "{tmp}/a.h5", "--quiet"],
    ["fit", "fits/real/encoder_pendulum_jensen.toml", "--method", "emcee", "--steps", "40", "--out", "{tmp}/e.h5",
     "--quiet"],
    ["fit", "fits/monday_unit3.toml", "--out", "{tmp}/b.h5", "--quiet"],
    ["fit", "fits/real/string_pendulum_lab1.toml", "--method", "leastsq", "--out", "{tmp}/c.h5", "--quiet"],
    ["init", "datasets/real/phy180_pendulum_lefebvre/q2_data.csv", "--pendulum", "--out", "{tmp}/d.toml"],
)


def _compile(folder: Path, root: Path) -> None:
    """Run :data:`WORKLOADS` in this process (from the checkout ``root``), then store its kernels."""
    from click.testing import CliRunner

    from .main import cli

    os.chdir(root)
    with tempfile.TemporaryDirectory() as tmp:
        for args in WORKLOADS:
            result = CliRunner().invoke(cli, [a.format(tmp=tmp) for a in args])
            if result.exit_code not in (0, 3):
                raise SystemExit(f"escfit {' '.join(args)} failed: {result.output[-2000:]}")
    print(f"stored {save_all(folder, compiled_kernels())} compiled kernels")


def build(root: Path | None = None) -> None:
    """Compile the store afresh in a child process and replace ``escfit/_kernels`` with it."""
    root = Path(root or Path(__file__).resolve().parents[2])
    with tempfile.TemporaryDirectory() as tmp:
        fresh = Path(tmp) / "_kernels"
        fresh.mkdir()
        env = dict(os.environ, NUMBA_CPU_NAME=GENERIC, NUMBA_CPU_FEATURES="", NUMBA_CACHE_DIR=str(Path(tmp) / "numba"),
                   ESCFIT_KERNEL_STORE="0", ESCFIT_QUIET_COMPILE="1")
        subprocess.run([sys.executable, "-m", "escfit.cli.kernel_build", "--compile", str(fresh), str(root)],
                       env=env, check=True)
        (fresh / "README.txt").write_text(
            "Kernels compiled by numba for its generic x86-64 processor: see escfit/core/kernel_store.py.\n"
            "Rebuild with: python -m escfit.cli.kernel_build\n")
        shutil.rmtree(STORE, ignore_errors=True)
        shutil.copytree(fresh, STORE)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--compile"]:
        _compile(Path(sys.argv[2]), Path(sys.argv[3]))
    else:
        build()
