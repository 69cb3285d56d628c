"""``escfit examples DIR``: copy the example recordings, scenes and fit recipes into DIR.

An installed wheel carries them as ``escfit/_examples/{datasets,fits}`` (copied in at build
time, see ``setup.py``); an editable install or a source checkout reads the repository's
``datasets/`` and ``fits/``.  Their layout is kept, so the recipes' relative paths work:
``cd DIR && escfit fit fits/monday_unit3.toml`` runs as it does in the repository.  DIR defaults
to ``~/escfit-examples`` (outside the clone); a second run into the same folder keeps what is
there and copies what is missing, so the README's one-liner can be run again.
"""

from __future__ import annotations

import shlex
import shutil
from pathlib import Path

import click

__all__ = ["examples", "examples_root", "copy_examples", "default_folder", "EXAMPLE_TREES", "QUICK_START"]

EXAMPLE_TREES = ("datasets", "fits")
QUICK_START = "fits/real/encoder_pendulum_jensen.toml"  # the README's first fit: a pendulum
SKIP_NAMES = frozenset({"__pycache__", ".ipynb_checkpoints", ".DS_Store"})
SKIP_SUFFIXES = frozenset({".pyc", ".pyo", ".part"})


def examples_root() -> Path | None:
    """The folder holding ``datasets/`` and ``fits/``: the installed copy, else the source checkout's.

    Returns
    -------
    pathlib.Path or None
        None when neither is there (a wheel built without the examples).
    """
    package = Path(__file__).resolve().parents[1]
    for root in (package / "_examples", package.parent):
        if all((root / name).is_dir() for name in EXAMPLE_TREES):
            return root
    return None


def _files(root: Path) -> list[Path]:
    """The example files under ``root``, relative to it, without caches and compiled files."""
    out = []
    for name in EXAMPLE_TREES:
        for p in sorted((root / name).rglob("*")):
            rel = p.relative_to(root)
            if p.is_file() and not SKIP_NAMES.intersection(rel.parts) and p.suffix not in SKIP_SUFFIXES:
                out.append(rel)
    return out


def copy_examples(dest: str | Path, *, force: bool = False, root: Path | None = None) -> list[Path]:
    """Copy the example trees into ``dest``.

    Parameters
    ----------
    dest
        Target folder; created if missing.  Example files already there with the shipped
        content are kept (a second run copies nothing); one that differs is refused unless
        ``force``.  Other files (a fit's results) are left alone.
    force
        Replace example files that differ from the shipped ones.
    root
        Where the examples are (default :func:`examples_root`).

    Returns
    -------
    list of pathlib.Path
        The files written, relative to ``dest`` (none when all were there already).

    Raises
    ------
    escfit.ResultsError
        ``dest`` is a file, or holds an example file that differs, without ``force``; no
        examples installed.
    """
    from ..core.atomic import atomic_path
    from ..core.errors import ResultsError

    root = examples_root() if root is None else root
    if root is None:
        raise ResultsError("this installation has no example files (a wheel built without datasets/ and fits/); "
                           "get them from the source repository", "escfit examples")
    target = Path(dest)
    if target.exists() and not target.is_dir():
        raise ResultsError("not a folder", str(target))
    files = _files(root)
    changed = [rel for rel in files if (target / rel).exists() and not _same(root / rel, target / rel)]
    if changed and not force:
        raise ResultsError(f"folder is not empty and {changed[0]} differs from the shipped example"
                           f"{f' (and {len(changed) - 1} more)' if len(changed) > 1 else ''}; pass --force to "
                           "replace them, or give another folder", str(target))
    _refuse_special(target, [rel for rel in files if rel in changed or not (target / rel).exists()])
    written = []
    for rel in files:
        out = target / rel
        if out.exists() and rel not in changed:
            continue  # the shipped file is already there: a second run reuses it
        out.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out, force=force) as tmp:
            shutil.copyfile(root / rel, tmp)
        written.append(rel)
    return written


def _refuse_special(target: Path, files: list[Path]) -> None:
    """Refuse, before copying anything, a destination where the place of an example file to be
    written (``files``) holds something that is never replaced (a folder, link, FIFO, device; see
    :func:`escfit.core.atomic.refuse_existing`) or one of its folders is something else."""
    from ..core.atomic import existing_kind
    from ..core.errors import ResultsError

    for rel in files:
        for parent in list(reversed(rel.parents))[1:]:
            kind = existing_kind(target / parent)
            if kind not in (None, "folder"):
                raise ResultsError(f"is a {kind}, where the examples need a folder; nothing was copied: move it "
                                   "away or give another folder", str(target / parent))
        kind = existing_kind(target / rel)
        if kind not in (None, "regular file"):
            raise ResultsError(f"is a {kind}, where an example file goes; it is never replaced (--force or not) "
                               "and nothing was copied: move it away or give another folder", str(target / rel))


def _same(a: Path, b: Path) -> bool:
    """Whether two files hold the same bytes (sizes first)."""
    import filecmp

    try:
        return b.is_file() and filecmp.cmp(a, b, shallow=False)
    except OSError:
        return False


def default_folder() -> Path:
    """``escfit-examples`` in the home folder: outside any clone, the same folder at every run."""
    return Path.home() / "escfit-examples"


@click.command("examples")
@click.argument("dest", type=click.Path(file_okay=False), required=False)
@click.option("--force", is_flag=True, help="Replace example files in DEST that differ from the shipped ones.")
def examples(dest, force):
    """Copy example recordings, scenes and fit recipes into DEST (default ~/escfit-examples).

    DEST gets datasets/ (recordings and scenes, with the LICENSE and SOURCE.txt files of the
    real recordings) and fits/ (fit recipes whose paths are relative to them).  Run again, it
    keeps the files already there with the shipped content and copies only what is missing.
    """
    dest = str(default_folder()) if dest is None else dest
    written = copy_examples(dest, force=force)
    files = _files(examples_root())
    recipes = sum(1 for f in files if f.parts[0] == "fits" and f.suffix == ".toml")
    kept = len(files) - len(written)
    how = f"copied {len(written)} files" + (f", kept {kept} already there" if kept else "")
    click.echo(f"{how} in {dest}: datasets/ (recordings and scenes) and fits/ ({recipes} fit recipes)")
    click.echo("next:")
    where = shlex.quote(str(dest))
    click.echo(f"  cd {where} && escfit fit {QUICK_START} --report {Path(QUICK_START).stem}.html")
    click.echo(f"  cd {where} && escfit fit fits/monday_unit3.toml --report monday_unit3.html")
