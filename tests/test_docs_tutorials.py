"""Every command the documentation shows either runs as written or is checked against the CLI.

Every fenced ``bash`` block of a page under ``docs/`` sits right after one of two MyST comment
lines (invisible on the site):

- ``% tested``: commands a reader can type as they stand.  The slow test runs each page's tested
  blocks in page order, in one bash shell per page (so ``cd`` carries over), in a fresh temporary
  folder, with this checkout's escfit first on the path and a time limit; a block that fails
  fails the page, with its output.  A page whose first block does not make its own folder runs in
  a fresh copy of the examples (``escfit examples``), which is where the pages tell a reader to
  run them.
- ``% shown: <why>``: commands that cannot run here as they stand (an install, a cluster, a
  reader's own file, a usage line with placeholders).  The fast tests check that each ``escfit``
  command they use exists and that every ``--option`` they give is one of that command's, with a
  value its choices allow.
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
ALL_PAGES = sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)
PAGE_LIMIT_S = 900  # a page's commands together; the longest (a quick-start emcee fit) takes 1-2 minutes
EXAMPLES_FIRST = "escfit examples escfit-examples >/dev/null && cd escfit-examples"

_FENCE = re.compile(r"^% tested[^\n]*\n```bash\n(.*?)^```", re.S | re.M)
_SHOWN = re.compile(r"^% shown: *(\S[^\n]*)\n```bash\n(.*?)^```", re.S | re.M)


def marked_blocks(page: Path) -> list[str]:
    """The tested ``bash`` blocks of a page, in order."""
    return _FENCE.findall(page.read_text(encoding="utf-8"))


def shown_blocks(page: Path) -> list[str]:
    """The ``bash`` blocks of a page marked ``% shown: <why>``, in order."""
    return [block for _why, block in _SHOWN.findall(page.read_text(encoding="utf-8"))]


def unmarked_blocks(text: str) -> list[int]:
    """Line numbers (1-based) of ``bash`` fences with neither mark on the line before."""
    lines = text.splitlines()
    marked = lambda before: before.startswith("% tested") or re.match(r"% shown: *\S", before)  # noqa: E731
    return [i + 1 for i, line in enumerate(lines)
            if line.rstrip() == "```bash" and not (i and marked(lines[i - 1].strip()))]


PAGES = [p for p in ALL_PAGES if marked_blocks(p)]


def escfit_command_lines(block: str) -> list[list[str]]:
    """The words of each ``escfit`` command a block runs, from the subcommand on."""
    out = []
    for line in block.replace("\\\n", " ").splitlines():
        for part in re.split(r"&&|\|\||;|\|", line):
            words = shlex.split(part, comments=True) if part.strip() else []
            if words and words[0] == "escfit" and len(words) > 1 and not words[1].startswith("-"):
                out.append(words[1:])
    return out


def escfit_commands(block: str) -> list[str]:
    """The ``escfit`` subcommands a block runs (``escfit fit ...`` -> ``fit``)."""
    return [words[0] for words in escfit_command_lines(block)]


def option_problems(words: list[str], cli) -> list[str]:
    """What in one shown ``escfit`` command the CLI would not accept (unknown options, bad choices).

    Usage notation is read as such: ``[--a X]`` and ``[...]`` are optional parts, ``a|b``
    alternatives (each must be allowed), upper-case words placeholders.  File arguments are not
    checked (a reader's own file).
    """
    import click

    cmd = cli.get_command(click.Context(cli), words[0])
    if cmd is None:
        return [f"no command 'escfit {words[0]}'"]
    opts = {o: p for p in cmd.params if isinstance(p, click.Option) for o in p.opts + p.secondary_opts}
    problems = []
    tokens = [w.strip("[]") for w in words[1:]]
    for i, tok in enumerate(tokens):
        if not tok.startswith("--"):
            continue
        name = tok.split("=", 1)[0]
        if name not in opts:
            problems.append(f"escfit {words[0]} has no option {name}")
            continue
        param = opts[name]
        if param.is_flag or isinstance(param.type, (click.Path, click.File)):
            continue
        value = tok.split("=", 1)[1] if "=" in tok else (tokens[i + 1] if i + 1 < len(tokens) else "")
        for v in value.split("|"):
            if not v or v.isupper() or v.startswith("<") or ":" in v and v.split(":")[0] == "tcp":
                continue  # a placeholder (N, HOST) or an address, not a value to check
            try:
                param.type.convert(v, param, click.Context(cmd))
            except click.BadParameter as err:
                problems.append(f"escfit {words[0]} {name} {v}: {err.message}")
    return problems


@pytest.mark.parametrize("page", ALL_PAGES, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_every_block_is_tested_or_shown(page):
    lines = unmarked_blocks(page.read_text(encoding="utf-8"))
    assert not lines, (f"{page.relative_to(ROOT)}: bash blocks at lines {lines} are neither '% tested' nor "
                       "'% shown: <why>'")


def test_shown_commands_match_the_cli():
    from escfit.cli.main import cli

    problems = [f"{page.relative_to(ROOT)}: {p}" for page in ALL_PAGES for block in shown_blocks(page)
                for words in escfit_command_lines(block) for p in option_problems(words, cli)]
    assert not problems, "\n".join(problems)


def test_readme_commands_match_the_cli():
    """The README carries no marks (it is read on the repository's front page): all its commands are checked."""
    from escfit.cli.main import cli

    blocks = re.findall(r"^```bash\n(.*?)^```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S | re.M)
    lines = [words for block in blocks for words in escfit_command_lines(block)]
    assert {"examples", "fit", "init"} <= {words[0] for words in lines}
    problems = [p for words in lines for p in option_problems(words, cli)]
    assert not problems, "\n".join(problems)


def test_tested_commands_match_the_cli():
    from escfit.cli.main import cli

    used = [(page, words) for page in PAGES for block in marked_blocks(page) for words in escfit_command_lines(block)]
    assert used, "no escfit command found in the tested blocks"
    problems = [f"{page.relative_to(ROOT)}: {p}" for page, words in used for p in option_problems(words, cli)]
    assert not problems, "\n".join(problems)


def test_option_check_catches_slips():
    from escfit.cli.main import cli

    assert option_problems(["fit", "a.csv", "--methd", "emcee"], cli) == ["escfit fit has no option --methd"]
    assert option_problems(["fit", "a.csv", "--method", "leastsq|mcmc"], cli)[0].startswith("escfit fit --method mcmc")
    assert option_problems(["fit", "a.csv", "--steps", "many"], cli)[0].startswith("escfit fit --steps many")
    assert option_problems(["fit", "a.csv", "--steps", "N", "--moves", "de"], cli) == []
    assert option_problems(["fit-many", "DATA...", "[--method", "leastsq|emcee]", "[--workers", "N]"], cli) == []
    assert option_problems(["fitt", "a.csv"], cli) == ["no command 'escfit fitt'"]


def test_extraction_reads_only_marked_blocks(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("```bash\nnot me\n```\n\n% tested\n```bash\necho one\ncd x && escfit fit a\n```\n"
                    "% tested: slow\n```bash\nescfit summary b.h5 | head\n```\n"
                    "% shown: a cluster\n```bash\nescfit fit-many x --workers 2\n```\n", encoding="utf-8")
    blocks = marked_blocks(page)
    assert blocks == ["echo one\ncd x && escfit fit a\n", "escfit summary b.h5 | head\n"]
    assert [c for b in blocks for c in escfit_commands(b)] == ["fit", "summary"]
    assert shown_blocks(page) == ["escfit fit-many x --workers 2\n"]
    assert unmarked_blocks(page.read_text(encoding="utf-8")) == [1]


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_tutorial_commands_run(page, tmp_path):
    blocks = marked_blocks(page)
    if not blocks[0].lstrip().startswith("escfit examples"):
        blocks = [EXAMPLES_FIRST + "\n", *blocks]
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
