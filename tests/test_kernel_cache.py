"""The on-disk cache of compiled kernels follows edits of the modules compiled into them.

numba stamps the cache of a ``cache=True`` function with a hash of its own file only, so a
kernel that calls a jitted helper of another module keeps the helper's old code after that
module is edited.  :func:`escfit.core.kernels.kernel` stamps it with every module of the
package the kernel's module imports.  Each experiment builds a tiny package in a temporary
directory (``dep.py``: helpers returning 1.0; ``user.py``: kernels calling them; ``other.py``:
imported by nobody), runs it in fresh interpreters with the numba cache inside the temporary
directory, edits ``dep.py`` only, and runs it again.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

from escfit.balance import dop853, exact, regions, rk4, solution
from escfit.core.kernels import kernel, kernel_sources

from .conftest import ROOT

DECORATORS = {
    # the scheme of escfit: numba.njit(cache=True) plus the sources compiled in
    "kernel": "from escfit.core.kernels import kernel as jit",
    # numba's own scheme, kept here to document why escfit does not rely on it
    "njit": "import functools, numba\njit = functools.partial(numba.njit, cache=True)",
}

DEP = '''\
{decorator}


@jit
def f():
    return {value}


@jit(inline="always")
def f_inline():
    return {value}
'''

USER = '''\
from numba import prange

{decorator}
from .dep import f, f_inline


@jit
def g():
    return f()


@jit
def g_inline():
    return f_inline()


@jit(parallel=True)
def g_parallel():
    acc = 0.0
    for i in prange(4):
        acc += f()
    return acc / 4.0
'''

RUNNER = '''\
import json
from tinypkg import user

out = {}
for name in ("g", "g_inline", "g_parallel"):
    disp = getattr(user, name)
    value = disp()
    out[name] = [value, sum(disp.stats.cache_hits.values()), sum(disp.stats.cache_misses.values())]
print(json.dumps(out))
'''


def _write_dep(pkg: Path, decorator: str, value: str) -> None:
    (pkg / "dep.py").write_text(DEP.format(decorator=decorator, value=value))


def _run(root: Path) -> dict[str, tuple[float, int, int]]:
    """Run the package in a fresh interpreter: ``{kernel: (value, cache hits, cache misses)}``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(root / "numba_cache"), PYTHONPATH=str(root))
    env.pop("NUMBA_DISABLE_JIT", None)
    # -B: no .pyc, whose mtime check (1 s resolution) could miss an edit of dep.py that keeps its size
    proc = subprocess.run([sys.executable, "-B", "-c", RUNNER], cwd=root, env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return {k: tuple(v) for k, v in json.loads(proc.stdout.splitlines()[-1]).items()}


@pytest.fixture(scope="module")
def experiments(tmp_path_factory) -> dict[str, list[dict]]:
    """Runs per scheme: cold; after an edit of an unrelated module (escfit's scheme only: the
    plain one ignores it anyway); after an edit of dep.py."""
    results = {}
    for scheme, decorator in DECORATORS.items():
        root = tmp_path_factory.mktemp(scheme)
        pkg = root / "tinypkg"
        pkg.mkdir()
        (pkg / "__init__.py").write_text("")
        (pkg / "other.py").write_text("X = 1\n")
        (pkg / "user.py").write_text(USER.format(decorator=decorator))
        _write_dep(pkg, decorator, "1.0")
        user_before = (pkg / "user.py").read_bytes(), os.stat(pkg / "user.py").st_mtime_ns
        runs = [_run(root)]
        if scheme == "kernel":
            (pkg / "other.py").write_text("X = 2  # not imported by user.py\n")
            runs.append(_run(root))
        _write_dep(pkg, decorator, "2.0")  # same size: only the content changes
        assert ((pkg / "user.py").read_bytes(), os.stat(pkg / "user.py").st_mtime_ns) == user_before
        runs.append(_run(root))
        results[scheme] = runs
    return results


KERNELS = ("g", "g_inline", "g_parallel")


def test_cache_is_used_when_nothing_compiled_in_changed(experiments):
    cold, warm, _ = experiments["kernel"]
    for name in KERNELS:
        assert cold[name] == (1.0, 0, 1), name  # compiled
        assert warm[name] == (1.0, 1, 0), name  # loaded from the cache, unrelated edit ignored


def test_kernel_recompiles_after_an_edit_of_a_called_module(experiments):
    edited = experiments["kernel"][-1]
    for name in KERNELS:
        assert edited[name] == (2.0, 0, 1), name


def test_plain_njit_cache_returns_the_stale_helper(experiments):
    """numba 0.68 keys a kernel's cache on its own file only: after the edit of dep.py the
    cached kernels of user.py still run the old f (1.0), inlined or not, which is why
    escfit's kernels use :func:`escfit.core.kernels.kernel`.  Should a numba release track
    dependencies itself, this test fails and the workaround can be revisited."""
    cold, edited = experiments["njit"]
    for name in KERNELS:
        assert cold[name] == (1.0, 0, 1), name
        assert edited[name] == (1.0, 1, 0), name


@pytest.mark.parametrize("func", [exact.run_angle, exact.run_phase, exact.run_angle_many, exact.run_phase_many,
                                  solution._states_at, solution._level_times, solution._ascending,
                                  rk4._run_located, rk4._run_naive, dop853.run_dop853],
                         ids=lambda f: f"{f.__module__}.{f.__name__}")
def test_escfit_kernels_are_keyed_on_the_modules_compiled_into_them(func):
    balance = Path(exact.__file__).resolve().parent
    files = set(kernel_sources(func))
    assert Path(func.py_func.__code__.co_filename).resolve() in files
    assert {balance / "segment.py", balance / "regions.py"} <= files or func.__module__.endswith("solution")
    if func in (rk4._run_located, rk4._run_naive, dop853.run_dop853):
        # region helpers, status codes, the shared torque and the smooth effects it adds up
        assert {balance / "regions.py", balance / "acceleration.py", balance.parent / "core" / "status.py"} <= files
    if func.__module__.endswith("solution"):
        # the closed form, the integrators' steps and the torque they evaluate between stored states
        assert {balance / "segment.py", balance / "steps.py", balance / "acceleration.py"} <= files


def test_sources_adds_files_the_import_scan_cannot_see(tmp_path):
    table = tmp_path / "table.csv"  # e.g. data read into a constant at import time
    table.write_text("1,2\n")
    src = regions.applies.py_func
    copy = types.FunctionType(src.__code__, src.__globals__, "_applies_copy")  # not compiled here
    files = set(kernel_sources(kernel(sources=[table])(copy)))
    assert files == set(kernel_sources(regions.applies)) | {table.resolve()}


def test_every_compiled_kernel_of_the_package_goes_through_kernel():
    """A direct ``numba.njit``/``jit`` in escfit would bring back caches keyed on one file only."""
    import re
    from pathlib import Path

    import escfit

    root = Path(escfit.__file__).parent
    direct = re.compile(r"^\s*@(?:numba\.)?n?jit\b|^\s*from numba import .*\bn?jit\b", re.M)
    offenders = [str(p.relative_to(root)) for p in root.rglob("*.py")
                 if p.name != "kernels.py" and direct.search(p.read_text(encoding="utf-8"))]
    assert not offenders, f"use escfit.core.kernels.kernel instead of numba.njit in {offenders}"
    assert any("@kernel" in p.read_text(encoding="utf-8") for p in (root / "verge").glob("*.py"))


@pytest.mark.parametrize("walk, module", [(exact.run_angle, exact), (dop853.run_dop853, dop853),
                                          (rk4._run_located, rk4)], ids=["exact", "dop853", "rk4"])
def test_each_solvers_walk_is_keyed_on_the_walker_and_the_solvers_step(walk, module):
    """The walk is one source compiled once per solver with its step bound in: an edit of the
    walker or of the solver's module must recompile that copy, and the copies have their own
    cache files (distinct names)."""
    balance = Path(exact.__file__).resolve().parent
    files = set(kernel_sources(walk))
    assert {balance / "walker.py", Path(module.__file__).resolve()} <= files
    assert walk.py_func.__qualname__ == f"walk_{module.__name__.rsplit('.', 1)[-1]}"


def test_a_kernel_compiles_without_a_cache_where_none_can_be_written(tmp_path):
    """A read-only install without a writable home: no cache folder numba can use (the one of
    NUMBA_CACHE_DIR, the package's __pycache__, the user's cache folder).  Each is blocked by a
    regular file standing where a folder must be made (read-only folders do not stop root).
    The kernels compile without a cache and give their results, with one note in all."""
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where a folder would be made")
    pkg = tmp_path / "roinstall" / "rokernels"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "__pycache__").write_text("")  # numba cannot make its in-tree cache folder here
    (pkg / "k.py").write_text("from escfit.core.kernels import kernel\n\n\n@kernel\ndef twice(x):\n    return 2.0 * x\n"
                              "\n\n@kernel(inline='always')\ndef thrice(x):\n    return 3.0 * x\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path / "roinstall")]),
           "NUMBA_CACHE_DIR": str(blocked / "numba"), "HOME": str(blocked / "home"),
           "XDG_CACHE_HOME": str(blocked / "cache"), "PYTHONDONTWRITEBYTECODE": "1"}
    env.pop("ESCFIT_QUIET_COMPILE", None)
    r = subprocess.run([sys.executable, "-c", "from rokernels.k import twice, thrice; print(twice(2.5), thrice(2.0))"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["5.0", "6.0"]
    notes = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(notes) == 1 and notes[0].startswith("note: ") and "cache" in notes[0], r.stderr
