"""The README's quick-start line runs as written, twice in a row, from a fresh home folder; then its second example.

The line is read from the README itself (the fenced ``bash`` block whose command starts with
``escfit examples``), so the test follows the README when it changes.  It runs in bash with
this checkout's escfit first on the path and ``HOME`` a temporary folder, so the examples land
in ``$HOME/escfit-examples``, outside the clone.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def readme_line(prefix: str) -> str:
    """The one command line of the README's fenced ``bash`` blocks that starts with ``prefix``."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```bash\n(.*?)^```", text, re.S | re.M)
    lines = [line for block in blocks for line in block.splitlines() if line.startswith(prefix)]
    assert len(lines) == 1, lines
    return lines[0]


def quick_start_line() -> str:
    return readme_line("escfit examples")


def second_example_line() -> str:
    return readme_line("cd ~/escfit-examples")


def test_quick_start_line_is_a_pendulum_outside_the_clone():
    line = quick_start_line()
    assert "cd ~/escfit-examples" in line and "fits/real/encoder_pendulum_jensen.toml" in line
    # the line can be repeated only because it says --force, and the README says why
    assert "--force" in line and "a second run replaces the results" in (ROOT / "README.md").read_text()


@pytest.mark.slow  # three fits with reports: 1-3 min depending on the machine's load
def test_quick_start_line_runs_twice_in_a_row(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    env = {**os.environ, "HOME": str(home),
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]),
           "ESCFIT_QUIET_COMPILE": "1"}
    line = quick_start_line()
    outputs = []
    for _ in range(2):
        r = subprocess.run(["bash", "-c", f"set -eo pipefail\n{line}"], cwd=tmp_path, env=env, capture_output=True,
                           text=True, timeout=900, stdin=subprocess.DEVNULL)
        assert r.returncode == 0, f"{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
        outputs.append(r.stdout)
    folder = home / "escfit-examples"
    assert (folder / "encoder_pendulum_jensen.h5").is_file() and (folder / "encoder_pendulum_jensen.html").is_file()
    assert "copied 0 files" in outputs[1]  # the second run reuses the examples
    assert "The swing loses" in outputs[1]
    assert not list(tmp_path.glob("*.h5")) and not list(ROOT.glob("encoder_pendulum_jensen.*"))
    # the README's second example, from the same folder
    second = second_example_line()
    r = subprocess.run(["bash", "-c", f"set -eo pipefail\n{second}"], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=900, stdin=subprocess.DEVNULL)
    assert r.returncode == 0, f"{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    assert (folder / "monday_unit3.html").is_file()
