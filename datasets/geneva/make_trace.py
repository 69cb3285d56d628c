"""Make synthetic_four_pin_trace.csv: a driver-speed trace of four_pin.toml with known noise.

Truth: four_pin.toml (Meyer's four-pin mechanism, mu = 0.20, K = 0.08 lbf*inch), released at
rest, sampled every 0.5 ms for 0.1 s (DOP853, rtol 1e-11), plus Gaussian noise of sd
1 rad/s (seed 1973).  The sd column is left out: the fit scene fit_four_pin_trace.toml
estimates the noise.  Run from anywhere:

    python datasets/geneva/make_trace.py [--force]
"""

from __future__ import annotations

import sys
from pathlib import Path

from escfit.core.scene import load_scene
from escfit.geneva.data import write_speed_trace
from escfit.geneva.synthetic import synthetic_trace

HERE = Path(__file__).resolve().parent
DURATION, INTERVAL, SD, SEED = 0.1, 5e-4, 1.0, 1973


def main(force: bool = False) -> Path:
    scene = load_scene(HERE / "four_pin.toml")
    trace = synthetic_trace(scene, duration=DURATION, interval=INTERVAL, sd=SD, seed=SEED)
    out = HERE / "synthetic_four_pin_trace.csv"
    write_speed_trace(out, trace, with_sd=False, force=force, comments=[
        "source: synthetic, made by datasets/geneva/make_trace.py (escfit.geneva.synthetic.synthetic_trace)",
        "truth: four_pin.toml, mu = 0.20, K = 0.08 lbf*inch, I_d = 3e-6 and I_f = 50e-6 lbf*inch*s^2",
        f"noise: Gaussian, sd = {SD:g} rad/s, seed = {SEED}; released at rest at t = 0, samples every "
        f"{INTERVAL * 1e3:g} ms for {DURATION:g} s",
    ])
    return out


if __name__ == "__main__":
    print(main(force="--force" in sys.argv[1:]))
