"""What a source file imports, remembered between processes by the file's contents.

The compiled kernels' cache keys (:mod:`escfit.core.kernels`) follow the import closure of each
kernel's module, which is found by parsing the package's modules: about 0.14 CPU s at every
start of a command, more than numba's own cache lookups.  A parse's result depends only on the
file's bytes and its module name, so it is kept in a small JSON file under a BLAKE2 digest of
the bytes and the name: an edited file has a new digest and is parsed again, and a file that
comes back to an earlier content finds its earlier result.  Only the import statements are
kept (as module names); which module files they resolve to is decided afresh in every process.

The file lives beside numba's caches: in ``NUMBA_CACHE_DIR`` when set, else in the package's
``__pycache__``, else in the user's cache folder; where none can be written, nothing is kept and
every process parses (the results are the same, only slower).
"""

from __future__ import annotations

import ast
import atexit
import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Iterable

__all__ = ["import_requests"]

#: the cache file's name; the version is raised when the kept structure changes
FILE_NAME = "escfit-import-scan-1.json"

# the fields of a statement (or an except clause, a match case) that hold further statements
_BLOCKS = ("body", "orelse", "finalbody", "handlers", "cases")

#: the most results kept; beyond it only those this process used are written back
MAX_KEPT = 4000

_kept: dict | None = None  # digest -> requests, loaded on first use
_used: set = set()
_changed = False


def _statements(body: list) -> Iterable[ast.AST]:
    """Every statement of ``body`` and of the blocks nested in it (functions, classes, ``if``,
    ``try``, ...), without descending into expressions: an import is always a statement, and
    skipping the expressions makes the scan several times faster than ``ast.walk``."""
    todo = list(body)
    while todo:
        node = todo.pop()
        yield node
        for field in _BLOCKS:
            todo.extend(getattr(node, field, ()))


def _parse(data: bytes, path: Path, module: str) -> list[list]:
    """The import statements of a module's source as ``[name, fallback]`` pairs (absolute module
    names): ``from pkg import sub`` asks for ``pkg.sub`` and falls back to ``pkg`` when that is no
    module; ``import a.b`` asks for ``a.b`` alone (fallback None)."""
    tree = ast.parse(data, filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    requests = []
    for node in _statements(tree.body):
        if isinstance(node, ast.Import):
            requests += [[alias.name, None] for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                if node.level - 1 > len(parts) - 1:
                    continue  # beyond the top-level package: not ours
                parts = parts[:len(parts) - (node.level - 1)]
                base = ".".join(parts + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            for alias in node.names:
                requests.append([base, None] if alias.name == "*" else [f"{base}.{alias.name}", base])
    return requests


def _folder() -> Path | None:
    """Where the cache file lives (see the module docstring); None when nowhere is writable."""
    candidates = []
    if os.environ.get("NUMBA_CACHE_DIR"):
        candidates.append(Path(os.environ["NUMBA_CACHE_DIR"]))
    candidates.append(Path(__file__).resolve().parents[1] / "__pycache__")
    home = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    candidates.append(Path(home) / "escfit")
    for folder in candidates:
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(folder, os.W_OK):
            return folder
    return None


def _load() -> dict:
    global _kept
    if _kept is None:
        _kept = {}
        folder = _folder()
        if folder is not None:
            try:
                loaded = json.loads((folder / FILE_NAME).read_text(encoding="utf-8"))
                _kept = loaded if isinstance(loaded, dict) else {}
            except (OSError, ValueError):
                pass
        atexit.register(_save)
    return _kept


def _save() -> None:
    """Write the kept results if this process added any (atomically; failures are silent: the
    file is only a shortcut)."""
    if not _changed or _kept is None:
        return
    folder = _folder()
    if folder is None:
        return
    kept = _kept if len(_kept) <= MAX_KEPT else {k: v for k, v in _kept.items() if k in _used}
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".import-scan-", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(kept, fh)
        os.chmod(tmp, 0o644)  # as numba's cache files: readable by whoever runs the package
        os.replace(tmp, folder / FILE_NAME)
    except OSError:
        try:
            os.unlink(tmp)
        except (OSError, UnboundLocalError):
            pass


def import_requests(path: Path, module: str) -> list[list]:
    """The import statements of ``path`` (module ``module``), as :func:`_parse` gives them, from the
    kept results when the file's bytes were seen before."""
    global _changed
    data = path.read_bytes()
    key = hashlib.blake2b(data + b"\0" + module.encode(), digest_size=16).hexdigest()
    kept = _load()
    _used.add(key)
    requests = kept.get(key)
    if not isinstance(requests, list):
        requests = _parse(data, path, module)
        kept[key] = requests
        _changed = True
    return requests
