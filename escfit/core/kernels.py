"""Compiled kernels whose on-disk cache follows every source file compiled into them.

numba's ``cache=True`` stamps a function's cache with a hash of the one file that defines
it.  A kernel's machine code, however, also holds every jitted function it calls (compiled
into it, inlined or not) and every module-level constant it reads, wherever those are
defined: after an edit of :mod:`escfit.balance.segment`, a cached kernel of
:mod:`escfit.balance.exact` kept running the old ``propagate``.

:func:`kernel` is ``numba.njit(cache=True, ...)`` with a wider stamp: a SHA-256 fingerprint
of the defining module together with every module of the same top-level package that it
imports, directly or through the modules it imports (read from their ``import`` statements,
so nothing has to be listed or bumped by hand).  A kernel can reach other code only through
its module's globals, and those come from these imports, so any edit that can change the
compiled code changes the stamp; numba then finds the index stale, recompiles and overwrites
the cache files in place.  An edit of an unrelated module leaves the cache alone.

Not seen by the import scan, and to be named with ``sources=``: code reached only through a
dynamic import, jitted functions passed in as arguments, and data files read into constants
at import time.  Modules outside the package (numpy, scipy, numba itself) are outside the
fingerprint, as they are outside numba's own stamp (numba's version is checked separately).

The hook is numba's cache machinery (:mod:`numba.core.caching`, numba 0.68): the locator
numba picks for the function (``__pycache__``, ``NUMBA_CACHE_DIR`` or the user-wide
directory, unchanged) is wrapped so that its source stamp includes the fingerprint.
``tests/test_kernel_cache.py`` checks that an edit of a helper module recompiles a kernel
of another module that calls it, and that plain ``numba.njit(cache=True)`` does not.

Where numba can write no cache at all (a read-only install with no writable home, so no
usable ``NUMBA_CACHE_DIR``, ``__pycache__`` or user cache folder), or a save fails, kernels
are compiled without a cache and one note says so (:func:`notice_uncached`).

Compiling the larger kernels takes minutes on a first run (a fresh install, an upgrade, a
new machine or ``NUMBA_CACHE_DIR``), so the first time in a process that a cached kernel
finds no usable cache entry one line says so on stderr when that is a terminal
(:func:`notice_compilation`); warm runs print nothing, and neither do runs whose stderr is
captured (scripts, logs, tests).  ``ESCFIT_QUIET_COMPILE=1`` silences it.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import sys
import types
import weakref
from pathlib import Path
from typing import Any, Callable, Iterable

import numba
from numba.core import caching

from .import_scan import import_requests

__all__ = ["kernel", "kernel_sources", "module_sources", "notice_compilation", "notice_uncached", "compiled_kernels",
           "plain_python"]

# py_func -> (files hashed, fingerprint); read by the cache implementation when numba builds it
_SOURCES: "weakref.WeakKeyDictionary[Callable, tuple[tuple[Path, ...], str]]" = weakref.WeakKeyDictionary()


def _module_file(root: Path, name: str) -> Path | None:
    """The source file of module ``name`` under the import root ``root``, if it is there."""
    base = root.joinpath(*name.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


@functools.lru_cache(maxsize=None)
def _imported_modules(path: Path, module: str, top: str, root: Path) -> frozenset[Path]:
    """Files of package ``top`` that module ``module`` (source ``path``) imports from.

    Every import statement counts, including those inside functions or ``if`` blocks: taking
    one too many only costs a recompilation, one too few a stale cache.  The statements come
    from :func:`escfit.core.import_scan.import_requests` (parsed once per file content, kept
    between processes); which files they name is resolved here, in every process.
    """
    found: set[Path] = set()
    for name, fallback in import_requests(path, module):
        for candidate in (name, fallback):
            if candidate is None or candidate.split(".")[0] != top:
                continue
            file = _module_file(root, candidate)
            if file is not None:
                found.add(file)
                break
    return frozenset(found)


@functools.lru_cache(maxsize=None)
def _import_closure(path: Path, module: str) -> tuple[Path, ...]:
    """``path`` and every module of its top-level package it imports, transitively, sorted.

    Falls back to ``path`` alone when ``module`` does not match the file's place in a package
    (a script run as ``__main__``, say).
    """
    parts = module.split(".")
    depth = len(parts) if path.name == "__init__.py" else len(parts) - 1
    if module == "__main__" or depth >= len(path.parents):
        return (path,)
    root = path.parents[depth]
    if _module_file(root, module) != path:
        return (path,)
    names = {path: module}
    todo = [path]
    while todo:
        file = todo.pop()
        for dep in _imported_modules(file, names[file], parts[0], root):
            if dep not in names:
                rel = dep.relative_to(root).with_suffix("")
                names[dep] = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
                todo.append(dep)
    return tuple(sorted(names))


def _expand(sources: str | os.PathLike | Iterable[str | os.PathLike]) -> set[Path]:
    """Files named by ``sources``: files as given, directories as all their ``*.py`` files."""
    if isinstance(sources, (str, os.PathLike)):
        sources = [sources]
    files: set[Path] = set()
    for item in sources:
        p = Path(item).resolve()
        if p.is_dir():
            files.update(p.rglob("*.py"))
        elif p.is_file():
            files.add(p)
        else:
            raise FileNotFoundError(f"kernel source {str(p)!r} does not exist")
    return files


@functools.lru_cache(maxsize=None)
def _fingerprint(files: tuple[Path, ...]) -> str:
    """SHA-256 (hex) over the names and bytes of ``files`` (in the order given)."""
    h = hashlib.sha256()
    for f in files:
        data = f.read_bytes()
        name = os.fsencode(f.name)
        # lengths first, so that no two different file sets give the same byte stream
        h.update(len(name).to_bytes(8, "little") + name + len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()


class _FingerprintLocator(caching._CacheLocator):
    """numba's chosen locator, with the fingerprint added to its source stamp.

    The cache directory and file names are numba's, so ``NUMBA_CACHE_DIR`` and the
    ``__pycache__`` layout work as usual; a changed stamp makes numba treat the index as
    stale, recompile and overwrite the cache files instead of adding new ones.
    """

    def __init__(self, inner: caching._CacheLocator, fingerprint: str):
        self._inner = inner
        self._fingerprint = fingerprint

    def ensure_cache_path(self):
        self._inner.ensure_cache_path()

    def get_cache_path(self):
        return self._inner.get_cache_path()

    def get_source_stamp(self):
        return (self._inner.get_source_stamp(), "escfit-kernel-sources", self._fingerprint)

    def get_disambiguator(self):
        return self._inner.get_disambiguator()


class _KernelCacheImpl(caching.CompileResultCacheImpl):
    def __init__(self, py_func):
        super().__init__(py_func)
        self._locator = _FingerprintLocator(self._locator, _SOURCES[py_func][1])


# Whether this process has said that it compiles kernels (said once per process)
_NOTICE_GIVEN = False

# The families whose kernels take long to compile, by top-level subpackage
_WHAT = {"verge": "the verge integrator", "geneva": "the Geneva drive integrator",
         "balance": "the balance-wheel solvers", "friction": "the friction-rig model"}


def notice_compilation(py_func: Callable, *, stream=None) -> bool:
    """Say once per process, on stderr, that kernels are being compiled for this machine.

    Called when a cached kernel has no usable cache entry for a signature, that is when
    numba is about to compile it; later calls in the same process say nothing.

    Parameters
    ----------
    py_func
        The Python function of the kernel about to be compiled (names the family).
    stream
        Where to write.  Default ``sys.stderr``, and only when it is a terminal: the line is
        for someone waiting, and must not end up in output a program reads.

    Returns
    -------
    bool
        Whether the line was written.
    """
    global _NOTICE_GIVEN
    if _NOTICE_GIVEN or _quiet():
        return False
    if stream is None:
        stream = sys.stderr
        try:
            if stream is None or not stream.isatty():
                return False
        except (AttributeError, ValueError):  # replaced or closed stderr
            return False
    _NOTICE_GIVEN = True
    parts = str(getattr(py_func, "__module__", "") or "").split(".")
    what = _WHAT.get(parts[1] if len(parts) > 1 else "", "numerical kernels")
    _write(stream, f"escfit: compiling {what} for this machine (first run only, up to a few minutes)\n")
    return True


def _quiet() -> bool:
    """Whether ``ESCFIT_QUIET_COMPILE`` silences the notices."""
    return os.environ.get("ESCFIT_QUIET_COMPILE", "") not in ("", "0")


def _write(stream, text: str) -> bool:
    """Write ``text`` to ``stream``; False when there is no usable stream (closed, replaced, or a
    pipe whose reader left)."""
    try:
        stream.write(text)
        stream.flush()
    except (OSError, ValueError, AttributeError):
        return False
    return True


class _KernelCache(caching.FunctionCache):
    """numba's per-function cache (compile results) stamped with the kernel's fingerprint."""

    _impl_class = _KernelCacheImpl

    def load_overload(self, sig, target_context):
        """numba's cache lookup, then the kernels shipped with escfit
        (:mod:`escfit.core.kernel_store`); a miss of both means numba compiles next, which is
        announced."""
        data = super().load_overload(sig, target_context)
        if data is None:
            from . import kernel_store

            data = kernel_store.load(self, _SOURCES[self._py_func][1], sig, target_context)
        if data is None:
            notice_compilation(self._py_func)
        return data

    def save_overload(self, sig, data):
        """numba's cache save; a folder that cannot be written (any more) leaves the kernel
        compiled and uncached, said once (:func:`notice_uncached`), instead of failing the run."""
        try:
            super().save_overload(sig, data)
        except OSError:
            notice_uncached()


# Whether this process has said that compiled kernels cannot be cached (said once per process)
_UNCACHED_GIVEN = False


def notice_uncached(*, stream=None) -> bool:
    """Say once per process, on stderr, that kernels are compiled without an on-disk cache.

    Said when the first kernel compiles without a cache: no folder numba can write its cache
    in (``NUMBA_CACHE_DIR``, the package's ``__pycache__``, the user's cache folder; a
    read-only install with no writable home) or a cache that could not be saved.  Unlike the
    first-run notice it is said whether or not stderr is a terminal: every run of such an
    install compiles again, which someone must be told.  ``ESCFIT_QUIET_COMPILE=1`` silences it.

    Returns
    -------
    bool
        Whether the line was written.
    """
    global _UNCACHED_GIVEN
    if _UNCACHED_GIVEN or _quiet():
        return False
    _UNCACHED_GIVEN = True
    return _write(stream or sys.stderr, "note: no writable cache folder for compiled kernels (NUMBA_CACHE_DIR, the "
                  "package's __pycache__, the home cache folder): they are compiled in every run; set "
                  "NUMBA_CACHE_DIR to a writable folder to keep them\n")


class _Uncached(caching.NullCache):
    """No on-disk cache (none can be written): every compilation is said to be uncached, once."""

    def __init__(self, py_func: Callable) -> None:
        self._py_func = py_func

    def load_overload(self, sig, target_context):
        notice_uncached()
        return None


def kernel(func: Callable | None = None, /, *, sources=(), cache: bool = True, **options: Any):
    """``numba.njit`` with an on-disk cache that follows all the code compiled into the kernel.

    Use as ``@kernel`` or ``@kernel(parallel=True)``, ``@kernel(inline="always")``, ... in
    place of ``@numba.njit(cache=True, ...)``.

    Parameters
    ----------
    func
        The function to compile (when used as ``@kernel`` without parentheses).
    sources
        Further files, or directories (all their ``*.py`` files), whose contents key the
        cache: what the import scan cannot see (see the module docstring).  Default none:
        the defining module and the modules of its package it imports are always hashed.
    cache
        Cache the compiled code on disk (default).  ``False`` gives plain ``numba.njit``.
    **options
        Options of ``numba.njit`` (``parallel``, ``inline``, ``fastmath``, ...).

    Returns
    -------
    numba.core.registry.CPUDispatcher or function
        The compiled kernel, or ``func`` itself when ``NUMBA_DISABLE_JIT`` is set.
    """
    def wrap(fn: Callable) -> Callable:
        disp = numba.njit(**options)(fn)
        if not cache or disp is fn:  # NUMBA_DISABLE_JIT: plain Python, nothing to cache
            return disp
        path = Path(inspect.getfile(fn)).resolve()
        if not path.is_file():  # in a zip archive or a frozen executable: numba's own cache
            disp.enable_caching()
            return disp
        files = tuple(sorted(set(_import_closure(path, fn.__module__)) | _expand(sources)))
        _SOURCES[fn] = (files, _fingerprint(files))
        # What Dispatcher.enable_caching does, with the stamped cache instead of FunctionCache
        try:
            disp._cache = _KernelCache(fn)
        except RuntimeError:  # numba found no folder it can write its cache in (a read-only install)
            disp._cache = _Uncached(fn)
        _KERNELS.append(disp)
        return disp

    return wrap(func) if func is not None else wrap


# every cached kernel made by :func:`kernel` in this process (kernels live as long as their modules)
_KERNELS: list = []


def compiled_kernels() -> list:
    """``(dispatcher, fingerprint)`` of each cached kernel of this process (made by :func:`kernel`)
    that holds compiled code."""
    return [(d, _SOURCES[d.py_func][1]) for d in _KERNELS if d.overloads and isinstance(d._cache, _KernelCache)]


def module_sources(path: Path, module: str) -> tuple[Path, ...]:
    """The files a kernel defined in module ``module`` (source ``path``) is keyed on: that file
    and every module of its package it imports, transitively.

    For a kernel assembled from functions of another module (a jitted function bound into a
    copy of a shared loop): pass these as its ``sources=``.
    """
    return _import_closure(Path(path).resolve(), module)


def kernel_sources(obj: Callable) -> tuple[Path, ...]:
    """The files whose contents key the cache of a :func:`kernel` (dispatcher or function).

    Raises
    ------
    KeyError
        ``obj`` was not compiled by :func:`kernel` with caching.
    """
    return _SOURCES[getattr(obj, "py_func", obj)][0]


@functools.lru_cache(maxsize=None)
def plain_python(obj: Callable) -> Callable:
    """A kernel as plain Python, calling the plain Python of the kernels it calls.

    The same arithmetic as the compiled kernel, with nothing compiled or loaded: for a few scalar
    calls from Python in a process that needs no other compiled code (a report's chart), where
    loading numba's first compiled kernel costs about 0.4 s.  Kernels it calls are found among
    the names its code reads from its module's globals.
    """
    fn = getattr(obj, "py_func", obj)
    glob = dict(fn.__globals__)
    for name in fn.__code__.co_names:
        called = glob.get(name)
        if hasattr(called, "py_func"):
            glob[name] = plain_python(called)
    plain = types.FunctionType(fn.__code__, glob, fn.__name__, fn.__defaults__, fn.__closure__)
    plain.__doc__ = fn.__doc__
    return plain
