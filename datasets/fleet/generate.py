"""Regenerate the shipped synthetic fleets (one directory per generating model).

Each fleet has 20 units drawn from the model's preset population (escfit.study.preset),
recorded like Monday's rig: notch counts of a 6-degree notched balance every second cycle
for 16 cycles after release from the 6.28 rad banking angle, at fixture loads 330.66,
661.32 and 991.98 g, with a 0.03 rad reading jitter.  Every unit's generating scene and seed
are saved beside the recordings, so `escfit.study.record_unit` reproduces each unit.
scenes/<model>.toml are the fit scenes of the three models compared (C, R, X, kappa and the
reading jitter free).

Run from the repository root:  python datasets/fleet/generate.py
"""

from __future__ import annotations

from pathlib import Path

from escfit.study import MODELS, Rig, fit_scene, generate_fleet, preset

HERE = Path(__file__).resolve().parent
SEEDS = {"angle": 1965, "phase": 1966, "phase_drift": 1967}


def main() -> None:
    for model, seed in SEEDS.items():
        fleet = generate_fleet(preset(model, n_units=20, seed=seed), HERE / model, force=True)
        print(f"{fleet.path}: {len(fleet.units)} units")
    (HERE / "scenes").mkdir(exist_ok=True)
    for model in MODELS:  # the fit scenes of the model comparison, for `escfit fit-many --scene`
        (HERE / "scenes" / f"{model}.toml").write_text(fit_scene(Rig(), model))


if __name__ == "__main__":
    main()
