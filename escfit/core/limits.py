"""Sizes beyond any run escfit is for, refused before any work.

A typo of a few zeros would otherwise fill the memory or run for days: 1e8 walkers take
6.9 GB before the first step.  The limits are far above real use (32-100 walkers, 10^3-10^5
steps) and the memory a run's draws need is compared with the machine's.
"""

from __future__ import annotations

import os

from .errors import FitError

__all__ = ["WALKERS_MAX", "STEPS_MAX", "physical_memory", "check_sampler_size"]

WALKERS_MAX = 100_000
STEPS_MAX = 10_000_000
MEMORY_SHARE = 0.5  # of the machine's memory that a run's draws may take (copies included)


def physical_memory() -> int | None:
    """Bytes of physical memory, or ``None`` where the system does not say."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def check_sampler_size(walkers: int, steps: int, ndim: int) -> None:
    """Refuse a sampler run too large to hold: more than :data:`WALKERS_MAX` walkers or
    :data:`STEPS_MAX` steps, or draws needing more than half the machine's memory.

    Parameters
    ----------
    walkers, steps, ndim
        Ensemble size, run length (an automatic run's cap) and free parameters.

    Raises
    ------
    FitError
        Naming the sizes and the memory needed.
    """
    if walkers > WALKERS_MAX:
        raise FitError(f"walkers = {walkers} is more than {WALKERS_MAX}; 32-100 walkers sample any escfit posterior")
    if steps > STEPS_MAX:
        raise FitError(f"steps = {steps} is more than {STEPS_MAX}")
    need = 2.0 * walkers * steps * (ndim + 1) * 8  # chain and log-probabilities, and one copy of them
    have = physical_memory()
    if have is not None and need > MEMORY_SHARE * have:
        raise FitError(f"{walkers} walkers x {steps} steps x {ndim} parameters need about {need / 1e9:.3g} GB for the "
                       f"draws; this machine has {have / 1e9:.3g} GB: use fewer walkers or steps")
