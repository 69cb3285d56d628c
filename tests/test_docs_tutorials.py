"""The documentation's tutorials run as written.

A fenced ``bash`` block right after a ``% tested`` line (a MyST comment, invisible on the
site) in ``docs/getting-started.md``, ``docs/howto/formats.md`` or ``docs/tutorials/*.md``
holds commands a reader is told to type.  The slow test runs each page's tested blocks in page order, in one bash shell per
page (so ``cd`` carries over), in a fresh temporary folder, with this checkout's escfit first
on the path and a time limit; a block that fails fails the page, with its output.  The fast
tests check that every page has tested blocks and that each ``escfit`` command they use exists.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [DOCS / "getting-started.md", DOCS / "howto" / "formats.md", *sorted((DOCS / "tutorials").glob("*.md"))]
PAGES = [p for p in PAGES if p.is_file() and p.name != "index.md"]
PAGE_LIMIT_S = 900  # a page's commands together; the longest (a quick-start emcee fit) takes 1-2 minutes

_FENCE = re.compile(r"^% tested[^\n]*\n```bash\n(.*?)^```", re.S | re.M)


def marked_blocks(page: Path) -> list[str]:
    """The tested ``bash`` blocks of a page, in order."""
    return _FENCE.findall(page.read_text(encoding="utf-8"))


def escfit_commands(block: str) -> list[str]:
    """The ``escfit`` subcommands a block runs (``escfit fit ...`` -> ``fit``)."""
    out = []
    for line in block.replace("\\\n", " ").splitlines():
        for part in re.split(r"&&|\|\||;|\|", line):
            words = shlex.split(part, comments=True) if part.strip() else []
            if words and words[0] == "escfit" and len(words) > 1 and not words[1].startswith("-"):
                out.append(words[1])
    return out


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_page_has_tested_commands(page):
    assert marked_blocks(page), f"{page.name} has no '% tested' bash block"


def test_tested_commands_exist():
    import click

    from escfit.cli.main import cli

    known = set(cli.list_commands(click.Context(cli)))  # lazily loaded commands included
    used = {(page.name, cmd) for page in PAGES for block in marked_blocks(page) for cmd in escfit_commands(block)}
    assert used, "no escfit command found in the tutorials"
    missing = sorted((page, cmd) for page, cmd in used if cmd not in known)
    assert not missing, f"tutorials run escfit commands that do not exist: {missing}"


def test_extraction_reads_only_marked_blocks(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("```bash\nnot me\n```\n\n% tested\n```bash\necho one\ncd x && escfit fit a\n```\n"
                    "% tested: slow\n```bash\nescfit summary b.h5 | head\n```\n", encoding="utf-8")
    blocks = marked_blocks(page)
    assert blocks == ["echo one\ncd x && escfit fit a\n", "escfit summary b.h5 | head\n"]
    assert [c for b in blocks for c in escfit_commands(b)] == ["fit", "summary"]


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_tutorial_commands_run(page, tmp_path):
    blocks = marked_blocks(page)
    script = "set -euo pipefail\n" + "\n".join(
        f"echo '>>> block {i + 1}'\n{block}" for i, block in enumerate(blocks))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]),
           "ESCFIT_QUIET_COMPILE": "1", "ESCFIT_DOCS_ROOT": str(ROOT)}
    # a session of its own, so that a time-out ends the escfit processes the shell started too
    proc = subprocess.Popen(["bash", "-c", script], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=PAGE_LIMIT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _err = proc.communicate()
        pytest.fail(f"{page.name}: the commands took over {PAGE_LIMIT_S} s\n{out[-3000:]}")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, f"{page.name}: exit {proc.returncode}\n--- stdout\n{out[-4000:]}\n--- stderr\n{err[-4000:]}"
