"""``escfit examples DIR``: copy the example recordings, scenes and fit recipes into DIR.

An installed wheel carries them as ``escfit/_examples/{datasets,fits}`` (copied in at build
time, see ``setup.py``); an editable install or a source checkout reads the repository's
``datasets/`` and ``fits/``.  Their layout is kept, so the recipes' relative paths work:
``cd DIR && escfit fit fits/monday_unit3.toml`` runs as it does in the repository.
"""

from __future__ import annotations

import shlex
import shutil
from pathlib import Path

import click

__all__ = ["examples", "examples_root", "copy_examples", "EXAMPLE_TREES"]

EXAMPLE_TREES = ("datasets", "fits")
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
        Target folder; created if missing.  A non-empty folder is refused unless ``force``.
    force
        Copy into a non-empty folder and replace files already there.
    root
        Where the examples are (default :func:`examples_root`).

    Returns
    -------
    list of pathlib.Path
        The files written, relative to ``dest``.

    Raises
    ------
    escfit.ResultsError
        ``dest`` is a file, or a non-empty folder without ``force``; no examples installed.
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
    if target.is_dir() and any(target.iterdir()) and not force:
        raise ResultsError("folder is not empty; pass --force to copy into it (files of the same name are "
                           "replaced)", str(target))
    files = _files(root)
    for rel in files:
        out = target / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out, force=force) as tmp:
            shutil.copyfile(root / rel, tmp)
    return files


@click.command("examples")
@click.argument("dest", type=click.Path(file_okay=False))
@click.option("--force", is_flag=True, help="Copy into a non-empty DEST, replacing files of the same name.")
def examples(dest, force):
    """Copy example recordings, scenes and fit recipes into DEST.

    DEST gets datasets/ (recordings and scenes, with the LICENSE and SOURCE.txt files of the
    real recordings) and fits/ (fit recipes whose paths are relative to them).
    """
    files = copy_examples(dest, force=force)
    recipes = sum(1 for f in files if f.parts[0] == "fits" and f.suffix == ".toml")
    click.echo(f"copied {len(files)} files into {dest}: datasets/ (recordings and scenes) and fits/ "
               f"({recipes} fit recipes)")
    click.echo("next:")
    click.echo(f"  cd {shlex.quote(str(dest))} && escfit fit fits/monday_unit3.toml --report monday_unit3.html")
