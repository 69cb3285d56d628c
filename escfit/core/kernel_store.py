"""Kernels compiled ahead of time for any x86-64 processor, shipped with escfit.

numba compiles a kernel the first time a process needs it on a machine and keeps the machine
code in its cache; for escfit's integrators that first compilation takes half a minute or more
(:mod:`escfit.core.kernels`).  The kernels a newcomer's first commands need (the examples'
fits, the record analysis) are compiled once, for numba's *generic* x86-64 processor
(``NUMBA_CPU_NAME=generic``: no instruction a 64-bit x86 processor may lack), and shipped in
``escfit/_kernels``, one numba index and data file per kernel as numba writes them.

When a kernel's own cache has no entry (:class:`escfit.core.kernels._KernelCache`), it is
looked up here before numba compiles: the entry must be for the same kernel source (the
fingerprint of every module compiled into it, :func:`escfit.core.kernels.kernel`), the same
numba version, the same Python version (in the file name), the same bytecode, signature and
target triple, and for the generic processor.  Anything else is a miss and numba compiles as
before; an unreadable or damaged entry is a miss too.  A kernel loaded from here runs the
generic processor's code: on the string pendulum's fit as fast as the host's to within the
machine's noise, with the same estimates to rounding.

Rebuilt by ``python -m escfit.cli.kernel_build`` after any change to a kernel or a module
compiled into it (``tests/test_kernel_store.py`` says when an entry is stale).  Turned off with
``ESCFIT_KERNEL_STORE=0``.
"""

from __future__ import annotations

import os
from pathlib import Path

from numba.core import caching

__all__ = ["STORE", "GENERIC", "load", "enabled", "stamp", "save_all"]

STORE = Path(__file__).resolve().parents[1] / "_kernels"
GENERIC = "generic"  # numba's processor name for code any x86-64 runs
_STAMP = "escfit-kernel-store"


def enabled() -> bool:
    """Whether kernels may be loaded from the store (``ESCFIT_KERNEL_STORE=0`` turns it off)."""
    return os.environ.get("ESCFIT_KERNEL_STORE", "1") != "0" and STORE.is_dir()


def stamp(fingerprint: str) -> tuple[str, str]:
    """The source stamp of a stored kernel: the fingerprint alone (no file times, which differ
    from one checkout to another)."""
    return (_STAMP, fingerprint)


class _Generic:
    """A stand-in for a codegen whose processor is numba's generic one on the host's triple."""

    def __init__(self, codegen) -> None:
        self._triple = codegen.magic_tuple()[0]

    def magic_tuple(self) -> tuple[str, str, str]:
        return (self._triple, GENERIC, "")


def _file(cache, fingerprint: str, folder: Path = STORE) -> caching.IndexDataCacheFile:
    return caching.IndexDataCacheFile(cache_path=str(folder), filename_base=cache._impl.filename_base,
                                      source_stamp=stamp(fingerprint))


def load(cache, fingerprint: str, sig, target_context):
    """The stored compile result of ``cache``'s kernel for ``sig``, or None (a miss).

    ``cache`` is the kernel's numba function cache; the entry is looked up under the key numba
    would use on a generic processor of this machine's triple.
    """
    if not enabled():
        return None
    try:
        key = cache._index_key(sig, _Generic(target_context.codegen()))
        data = _file(cache, fingerprint).load(key)
        return None if data is None else cache._impl.rebuild(target_context, data)
    except Exception:  # noqa: BLE001 - a damaged or foreign entry: numba compiles instead
        return None


def save_all(folder: Path, kernels) -> int:
    """Write every compiled overload of ``kernels`` (pairs of a dispatcher made by
    :func:`escfit.core.kernels.kernel` and its fingerprint) into ``folder``, from a process run
    with ``NUMBA_CPU_NAME=generic``; returns how many."""
    count = 0
    for disp, fingerprint in kernels:
        cache = disp._cache
        for sig, cres in list(disp.overloads.items()):
            if cres.library.codegen.magic_tuple()[1:] != (GENERIC, ""):
                raise RuntimeError("kernels for the store must be compiled with NUMBA_CPU_NAME=generic")
            if not cache._impl.check_cachable(cres):
                continue
            _file(cache, fingerprint, folder).save(cache._index_key(sig, cres.library.codegen),
                                                   cache._impl.reduce(cres))
            count += 1
    return count
