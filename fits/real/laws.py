"""Which damping law each real recording prefers: every gallery recording fitted with the candidate
laws and ranked by ``escfit compare`` (docs/real-data.md, "Which damping law").

Run:  python fits/real/laws.py [--out DIR] [NAME ...]   (least squares; 10-20 minutes for all)

For each recording of ``fits/real/gallery.py`` (the shipped recipes and, when present, the shared
GPL decays) the recipe's scene -- viscous damping plus Coulomb friction -- is fitted as it is and
with its laws changed: viscous damping alone, viscous damping plus quadratic air drag, all three,
and for the swings beyond 60 deg all three plus a stiffening (cubic) restoring term.  Every fit
is least squares as ``escfit fit`` runs it, written to ``DIR/NAME/LAW.h5``; the fits of one
recording are ranked by :func:`escfit.inference.compare.compare_fits` (AICc, the fewest
parameters among fits within 2).  Rate-gyro records are left out: their signal is the angular
velocity, for which only linear (viscous) damping carries over from the angle's equation.

Prints, per recording, the comparison table and its verdict, then one Markdown row per recording:
the law the verdict names, its coefficients with 95 % intervals, its dAICc to the next law, and
the misfit diagnostics still flagged at its best fit.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from gallery import records  # noqa: E402  (the recordings the gallery shows)

from escfit.core.scene import load_scene  # noqa: E402
from escfit.inference import fit  # noqa: E402
from escfit.inference.compare import compare_fits  # noqa: E402
from escfit.results import load_fit  # noqa: E402

#: recordings whose swing exceeds 60 deg: a stiffening term is a candidate too
LARGE = {"multiarm_estimation", "string_pendulum_trial1", "encoder_pendulum_jensen", "galileo_long",
         "galileo_short", "pohl_amplitudes", "pohl_tracker", "pohl_tracker_trk", "cassy_drehpendel"}
#: rate records (angular velocity): only linear laws carry over
RATE = {"gyro_torsion_radial", "gyro_compound_axial"}

DRAG = "\n[effects.drag]\nD = { value = 0.005, vary = true, min = 0, max = 2 }\n"
STIFF = "\n[effects.stiffening]\nk3 = { value = 0.02, vary = true, min = 0, max = 5 }\n"
SHORT = {"viscous": "V", "viscous+coulomb": "V+C", "viscous+drag": "V+D", "viscous+coulomb+drag": "V+C+D",
         "viscous+coulomb+drag+stiffening": "V+C+D+k3"}


def without_coulomb(text: str) -> str:
    """The scene text with its ``[effects.coulomb]`` table removed."""
    return re.sub(r"\n\[effects\.coulomb\]\n(?:(?!\n\[).)*", "\n", text, flags=re.S)


def candidates(name: str, text: str) -> dict[str, str]:
    """Law -> scene text, built from the recipe's viscous + Coulomb scene (none for a recipe that
    is itself a law variant of another, i.e. already has drag, or has no Coulomb friction)."""
    if "[effects.coulomb]" not in text or "[effects.drag]" in text:
        return {}
    plain = without_coulomb(text)
    out = {"viscous": plain, "viscous+coulomb": text, "viscous+drag": plain + DRAG, "viscous+coulomb+drag": text + DRAG}
    if name in LARGE:
        out["viscous+coulomb+drag+stiffening"] = text + DRAG + STIFF
    return out


def interval(res, key: str) -> str:
    lsq = res.group("least_squares")
    names = list(map(str, lsq["parameter"].values))
    if key not in names:
        return "-"
    i = names.index(key)
    v, lo, hi = (float(lsq[k].values[i]) for k in ("value", "lo95", "hi95"))
    if v <= 1e-6 * hi:  # on its lower bound 0: an upper limit
        return f"0 [0, {hi:.3g}] (bound)"
    return f"{v:.3g} [{lo:.3g}, {hi:.3g}]"


def misfit_words(res) -> str:
    """The misfit warnings of a fit, each shortened to its first clause."""
    words = [w.split(":")[0].split(" (")[0] for w in res.warnings if any(k in w for k in ("runs", "lag-1", "branches", "smooth"))]
    return "; ".join(words) or "clean"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="recordings to fit (default: all)")
    ap.add_argument("--out", default="law_fits", help="folder for the results files")
    args = ap.parse_args()
    rows = []
    for name, data, scene_path, title in records():
        if (args.names and name not in args.names) or name in RATE:
            continue
        laws = candidates(name, scene_path.read_text())
        if not laws:
            continue
        folder = Path(args.out) / name
        folder.mkdir(parents=True, exist_ok=True)
        files = {}
        for law, text in laws.items():
            scene = folder / f"{law}.toml"
            scene.write_text(text)
            files[law] = folder / f"{law}.h5"
            if not files[law].exists():
                fit(load_scene(str(scene)), str(data), out=files[law], seed=1)
        cmp = compare_fits(list(files.values()))
        print(f"\n### {name}: {title}\n")
        print(cmp.table())
        print(cmp.notes[-1], flush=True)
        by_file = {str(f): law for law, f in files.items()}
        chosen = by_file[cmp.choice]
        res = load_fit(files[chosen])
        order = [by_file[r["file"]] for r in cmp.rows]
        d = {by_file[r["file"]]: r["d_aicc"] for r in cmp.rows}
        runner = next(law for law in order if law != chosen)
        gap = d[runner] - d[chosen]
        rows.append(f"| {name} | {', '.join(SHORT[law] for law in order)} | **{SHORT[chosen]}** | "
                    f"{SHORT[runner]} {gap:+.1f} | {interval(res, 'viscous.C')} | {interval(res, 'coulomb.R')} | "
                    f"{interval(res, 'drag.D')} | {interval(res, 'stiffening.k3')} | {misfit_words(res)} |")
    print("\n| recording | laws by AICc, best first | verdict | next (dAICc) | C (1/s) | R (rad/s^2) | D (1/rad) | "
          "k3 (1/rad^2) | misfit at the verdict's fit |")
    print("|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
