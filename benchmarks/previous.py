"""The previous version of escfit, checked out from git into a temporary folder.

Benchmarks that compare against the previous version run it in a subprocess with
``PYTHONPATH`` pointing at ``git archive <rev> escfit`` unpacked under the system's temporary
directory (one folder per revision, so numba's cache of its kernels is reused by later runs),
and the current code in the same run.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def checkout(rev: str) -> Path:
    """Folder holding ``escfit/`` as of git revision ``rev`` (extracted once)."""
    sha = subprocess.run(["git", "rev-parse", "--short=12", rev], cwd=ROOT, check=True, capture_output=True,
                         text=True).stdout.strip()
    folder = Path(tempfile.gettempdir()) / f"escfit-previous-{sha}"
    if not (folder / "escfit" / "__init__.py").is_file():
        data = subprocess.run(["git", "archive", "--format=tar", sha, "escfit", "datasets/scenes",
                               "datasets/monday1965"], cwd=ROOT, check=True, capture_output=True).stdout
        folder.mkdir(exist_ok=True)
        with tarfile.open(fileobj=BytesIO(data)) as tar:
            tar.extractall(folder, filter="data")
    return folder


def run_in(folder: Path | None, script: Path, args: list[str]) -> dict:
    """Run ``script`` with ``escfit`` imported from ``folder`` (None: this checkout); its stdout's JSON."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(folder if folder is not None else ROOT)
    env.setdefault("ESCFIT_QUIET_COMPILE", "1")
    res = subprocess.run([sys.executable, str(script), *args], env=env, capture_output=True, text=True,
                         cwd=folder if folder is not None else ROOT)
    if res.returncode != 0:
        raise RuntimeError(f"{script.name} failed under {folder or ROOT}:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout)
