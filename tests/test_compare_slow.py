"""``escfit compare`` over many synthetic records that mix the damping laws (slow).

Records of a balance on a linear spring released at 1 rad, 40 half swings read with 3 mrad
Gaussian noise: half with viscous damping only, half with viscous damping and Coulomb friction
(2R/omega0^2 from 2.5 to 7.6 mrad per half swing).  Each record is fitted by least squares with
both laws, and the comparison's verdict picks the law (the best AICc, or the simpler law when
the two are within 2).  Asymptotically, on a record without dry friction the nesting fit gains
a likelihood ratio distributed as an equal mixture of 0 and chi-square(1) (R >= 0 is a bound),
so the verdict invents Coulomb friction with probability 0.5 P(chi2_1 > 4.46) = 1.7 % (the
extra parameter costs 2.46 in AICc at 41 readings, and the verdict asks for 2 more).

The seeds are fixed (numpy's PCG64 streams), so the outcome is the same on every run;
``ESCFIT_COMPARE_RECORDS`` (per law, default 20) measures the rates over more records.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from escfit import load_scene
from escfit.balance.synthetic.instruments import record
from escfit.inference import fit
from escfit.inference.compare import compare_fits

from .test_compare import FIT_V, FIT_VC, FREE_SIGMA, NOISE

pytestmark = pytest.mark.slow

PER_LAW = int(os.environ.get("ESCFIT_COMPARE_RECORDS", "20"))


def _verdict(cmp) -> str:
    return "viscous_coulomb" if cmp.choice.endswith("_vc.h5") else "viscous"


def test_compare_picks_the_true_damping_law(tmp_path):
    rng = np.random.default_rng(20231)
    fit_v, fit_vc = tmp_path / "v.toml", tmp_path / "vc.toml"
    fit_v.write_text(FIT_V + FREE_SIGMA)
    fit_vc.write_text(FIT_VC + FREE_SIGMA)
    outcome = {"viscous": [], "viscous_coulomb": []}
    for i in range(2 * PER_LAW):
        law = "viscous" if i % 2 == 0 else "viscous_coulomb"
        c = float(rng.uniform(0.03, 0.08))
        r = float(rng.uniform(0.05, 0.15)) if law == "viscous_coulomb" else 0.0
        truth = tmp_path / f"truth{i}.toml"
        truth.write_text(f'model = "balance"\n[oscillator]\nomega0 = {2 * math.pi!r}\ntheta0 = 1.0\n[run]\n'
                         f"swings = 40\n[effects.viscous]\nC = {c!r}\n"
                         + (f"[effects.coulomb]\nR = {r!r}\n" if r else ""))
        data = tmp_path / f"r{i}.csv"
        record(load_scene(truth), "unit-curve", data, noise=NOISE, seed=1000 + i, every=1)
        files = [tmp_path / f"r{i}_{m}.h5" for m in ("v", "vc")]
        for scene, out in zip((fit_v, fit_vc), files):
            fit(scene, data, out=out, seed=i, n_starts=2)
        outcome[law].append(_verdict(compare_fits(files)))
    invented = sum(v != "viscous" for v in outcome["viscous"])
    missed = sum(v != "viscous_coulomb" for v in outcome["viscous_coulomb"])
    right = 2 * PER_LAW - invented - missed
    print(f"\ntrue law chosen in {right} of {2 * PER_LAW} records; Coulomb friction invented in {invented} of "
          f"{PER_LAW} records without it; missed in {missed} of {PER_LAW} records with it")
    assert right >= math.ceil(0.95 * 2 * PER_LAW)
    assert invented <= PER_LAW / 20


# -- five laws, drag among them: the confusion table ------------------------------------------------
#: 20 records per law, 100 per way of reading: measured 98 of 100 on the waveform and 100 of 100 on
#: turning points (about 7 and 3.5 minutes alone); at 8 per law the waveform's 38 of 40 sat on the
#: threshold itself
MIXED_PER_LAW = int(os.environ.get("ESCFIT_COMPARE_LAW_RECORDS", "20"))


def _confusion(tmp_path, observation: str, per_law: int, seed0: int) -> dict:
    """Records of each law of ``law_records.LAWS`` fitted with every law, decided by the verdict:
    ``{true law: {chosen law: count}}``."""
    from .law_records import LAWS, fit_scene, make_record

    scenes = {}
    for law in LAWS:
        scenes[law] = tmp_path / f"fit_{law}.toml"
        scenes[law].write_text(fit_scene(law, observation))
    table = {law: {other: 0 for other in LAWS} for law in LAWS}
    for k, law in enumerate(LAWS):
        for i in range(per_law):
            rec = make_record(law, seed=seed0 + 100 * k + i)
            data = tmp_path / f"{law}_{i}.csv"
            data.write_text(rec.text)
            files = {}
            for cand, scene in scenes.items():
                files[cand] = tmp_path / f"{law}_{i}__{cand}.h5"
                fit(scene, data, out=files[cand], seed=i, n_starts=2)
            choice = compare_fits(list(files.values())).choice
            table[law][next(c for c, f in files.items() if str(f) == choice)] += 1
    return table


def _print_confusion(title: str, table: dict) -> None:
    laws = list(table)
    print(f"\n{title}\ntrue law \\ chosen  " + "  ".join(f"{c:>15}" for c in laws))
    for law in laws:
        print(f"{law:>18}  " + "  ".join(f"{table[law][c]:>15}" for c in laws))


@pytest.mark.parametrize("how", ["waveform", "turning points"])
def test_compare_picks_the_true_law_among_five_with_drag(tmp_path, how):
    """Pendulum records (``tests/law_records.py``) with viscous damping, Coulomb friction, drag,
    viscous + Coulomb or viscous + drag, each fitted with all five laws; the verdict (best AICc,
    the fewest parameters within 2, the best-ranked among equally simple ones) must name the true
    law in 95 % of the records, and invent drag (or Coulomb friction) on records without it in at
    most 1 in 20."""
    from .law_records import LAWS, TURNING_POINTS, WAVEFORM

    table = _confusion(tmp_path, WAVEFORM if how == "waveform" else TURNING_POINTS, MIXED_PER_LAW,
                       seed0=9000 if how == "waveform" else 9500)
    _print_confusion(f"{how}: {MIXED_PER_LAW} records per law", table)
    total = sum(sum(row.values()) for row in table.values())
    right = sum(table[law][law] for law in LAWS)
    has = {"drag": lambda law: "drag" in law, "coulomb": lambda law: "coulomb" in law}
    for effect, present in has.items():
        without = [law for law in LAWS if not present(law)]
        invented = sum(n for law in without for chosen, n in table[law].items() if present(chosen))
        print(f"{effect} invented in {invented} of {MIXED_PER_LAW * len(without)} records without it")
        assert invented <= MIXED_PER_LAW * len(without) / 20, (effect, table)
    print(f"true law chosen in {right} of {total}")
    assert right >= math.ceil(0.95 * total), table
