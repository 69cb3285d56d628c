"""Regenerate the example recordings of this folder from their scenes and seeds.

    python datasets/recordings/make_examples.py

Every file says in its first comment line (or, for JSON, in ``escfit.generated_by``) which
scene, recorder, noise and seed produced it.
"""

from __future__ import annotations

import math
from pathlib import Path

import escfit
from escfit.balance.synthetic.recorders import record

HERE = Path(__file__).resolve().parent
SCENES = HERE.parent / "scenes"

EXAMPLES = [
    # file, scene, recorder, noise, seed, recorder options
    ("monday_pulses.csv", HERE / "pulses_scene.toml", "pulses", 1e-4, 1, {"swings": 24}),
    ("monday_timegrapher.json", HERE / "timegrapher_scene.toml", "timegrapher", 0.5, 2, {"fmt": "json"}),
    ("monday_timegrapher_beats.csv", HERE / "timegrapher_scene.toml", "timegrapher", 0.5, 2,
     {"fmt": "csv", "swings": 60}),
    ("monday_timeseries.csv", HERE / "timeseries_scene.toml", "timeseries", 0.002, 3,
     {"swings": 40, "rate_hz": 400.0, "quantum": 2 * math.pi / 4096, "offset": 0.02, "unit": "deg"}),
]


def main() -> None:
    for name, scene_path, recorder, noise, seed, options in EXAMPLES:
        scene = escfit.load_scene(scene_path)
        out = record(scene, recorder, HERE / name, noise=noise, seed=seed, **dict(options))
        print(f"{out.name}: {out.stat().st_size / 1024:.1f} KB")


if __name__ == "__main__":
    main()
