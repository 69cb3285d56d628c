"""The standard study: the shipped fleets fitted by every model, sized by settings.

Notebooks and tests share one layout, ``<work>/<fleet>/<model>/<unit>.h5``, so a finished
unit is never fitted twice (:func:`escfit.study.fit_many` skips it).  Settings come from
arguments or from environment variables (``ESCFIT_STUDY_*``), which is how the notebook test
runs the notebooks small.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

from .batch import BatchResult, LazyClient, fit_fleet
from .fleet import load_fleet
from .scenes import MODELS

__all__ = ["StudySettings", "cross_fit", "results_dir"]


@dataclass(frozen=True)
class StudySettings:
    """How big a study run is.

    Attributes
    ----------
    fleets
        Directory holding one fleet per generating model (``datasets/fleet``).
    work
        Results root: ``<work>/<fleet>/<model>/``.
    units
        Units of the angle fleet fitted by the angle model (population estimates); None: all.
    chapter5_units
        Units of the angle fleet fitted by the phase models (Chapter V, comparison); None: all.
    cross_units
        Units of the phase and phase_drift fleets fitted by every model; None: all.
    walkers, steps, seed
        emcee settings of every unit fit and the batch seed.
    population_steps
        emcee steps of the population (hyperparameter) sampler.
    scheduler, workers
        Where to run (see :func:`escfit.study.fit_many`).
    """

    fleets: Path
    work: Path
    units: int | None = None
    chapter5_units: int | None = None
    cross_units: int | None = None
    walkers: int = 16
    steps: int = 600
    seed: int = 0
    population_steps: int = 1000
    scheduler: Any = None
    workers: int | None = None

    @classmethod
    def from_env(cls, fleets: str | Path, work: str | Path, **defaults: Any) -> "StudySettings":
        """Settings from ``ESCFIT_STUDY_{WORK,UNITS,CHAPTER5_UNITS,CROSS_UNITS,WALKERS,STEPS,SEED,
        POPULATION_STEPS,SCHEDULER,WORKERS}``, falling back to ``defaults`` and the class defaults."""
        env = os.environ.get
        base = replace(cls(Path(fleets), Path(env("ESCFIT_STUDY_WORK", str(work)))), **defaults)
        ints = {k: env(f"ESCFIT_STUDY_{k.upper()}") for k in ("units", "chapter5_units", "cross_units", "walkers",
                                                               "steps", "seed", "population_steps", "workers")}
        out = replace(base, **{k: int(v) for k, v in ints.items() if v not in (None, "")})
        if env("ESCFIT_STUDY_SCHEDULER"):
            out = replace(out, scheduler=env("ESCFIT_STUDY_SCHEDULER"))
        return out

    def plan(self) -> list[tuple[str, str, int | None]]:
        """(fleet, model, number of units) of every batch of the study."""
        out = []
        for fleet in MODELS:
            for model in MODELS:
                if fleet == "angle":
                    n = self.units if model == "angle" else self.chapter5_units
                else:
                    n = self.cross_units
                out.append((fleet, model, n))
        return out


def results_dir(settings: StudySettings, fleet: str, model: str) -> Path:
    return settings.work / fleet / model


def cross_fit(settings: StudySettings, *, scheduler: Any = None,
              progress: bool | Callable[[str], None] = False) -> dict[tuple[str, str], BatchResult]:
    """Fit every shipped fleet with every model (emcee), as :meth:`StudySettings.plan` says.

    Parameters
    ----------
    scheduler
        A ``distributed.Client`` (or :class:`~escfit.study.batch.LazyClient`) for all batches;
        default: one client, started only if some unit is left to fit, on the settings'
        scheduler or a local cluster of ``settings.workers`` processes.
    """
    own = scheduler is None and settings.workers != 0
    client = (LazyClient(settings.scheduler, settings.workers) if own else scheduler)
    out = {}
    try:
        for fleet, model, n in settings.plan():
            fl = load_fleet(settings.fleets / fleet)
            units = fl.units[:n] if n else None
            out[(fleet, model)] = fit_fleet(fl, model, results_dir(settings, fleet, model), units=units,
                                            walkers=settings.walkers, steps=settings.steps, seed=settings.seed,
                                            scheduler=client, workers=0 if client is None else None,
                                            progress=progress)
    finally:
        if own:
            client.close()
    return out
