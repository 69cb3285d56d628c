"""Regenerate ``tg_applog_example.csv``: a timegrapher app's log of a simulated decay.

    python datasets/recordings/make_tg_applog.py

The watch is the Monday-like unit of ``timegrapher_scene.toml`` (C = 0.6, R = 100,
X = 1500 at their scene values), stopped and released from the banking at 21:47:03.250; its
amplitude falls from 324 deg to the steady 179.5 deg within about 20 half swings.  The app
listens at 18000 bph, locks after three beats and updates its display on every second beat
(the tocs, half swings 4, 6, 8 ...) for 30 s with:

- the amplitude: the lift angle set in it (52 deg, equal to the true one) times the harmonic
  formula averaged over the toc and the tic before it
  (:func:`escfit.balance.observation.timegrapher.window_readings`), plus 0.5 deg noise, whole degrees;
- the rate over those two beats, s/day (0.1 s/d);
- the beat error, signed: half of (the last beat interval minus the one before), ms (0.1 ms),
  so positive when the beat the app updates on comes late; here the app updates on the tocs,
  which come 0.2 ms late (a beat error the scene does not model; it moves only beat times, not
  the amplitude);
- the time of the update's beat on the clock, to the millisecond; beats are heard with 0.1 ms
  noise on a 48 kHz clock.

The app's first update (still locking) and three later ones (noise) are flagged invalid
with junk values, and the log ends in the middle of a row, as when an app is stopped mid-write.
The ``Release`` settings line is escfit's addition (the instant the balance was let go, needed
to fit the decay); the rest is what an app writes.  Read it with
:func:`escfit.analysis.recordings.tg_applog.read_tg_applog` and fit it with ``beats = false``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import escfit
from escfit.balance import solve
from escfit.balance.observation.timegrapher import TimegrapherObservation, beat_events, window_readings

HERE = Path(__file__).resolve().parent
SCENE = HERE / "timegrapher_scene.toml"
OUT = HERE / "tg_applog_example.csv"
SEED = 7
BPH = 18000
LIFT_DEG = 52.0
SIGMA_DEG = 0.5  # amplitude reading noise
SIGMA_T = 1e-4  # beat timing noise, s
TOC_LATE_MS = 0.2  # signed beat error of the watch
RELEASE_CLOCK_S = 21 * 3600 + 47 * 60 + 3.250  # 21:47:03.250
RECORD_S = 30.0
FIRST_UPDATE = 4  # half swing of the app's first update (it updates on even half swings)
INVALID_LATER = 3  # noisy rows flagged invalid after the first


def clock(seconds: float) -> str:
    """``hh:mm:ss.sss`` of seconds since midnight."""
    ms = int(round(seconds * 1000.0)) % 86_400_000
    return f"{ms // 3_600_000:02d}:{ms // 60_000 % 60:02d}:{ms // 1000 % 60:02d}.{ms % 1000:03d}"


def make_rows(scene, rng: np.random.Generator) -> list[str]:
    """The log's table rows (header first), the last one complete."""
    swings = int(RECORD_S * scene.params["oscillator.omega0"].value / math.pi) + 4
    tr = solve(scene, "exact", swings=swings, dense=True)
    tz, pulse = beat_events(tr.dense, tr.amplitude.size, math.radians(LIFT_DEG))
    ok = np.isfinite(tz)
    tz, pulse = tz[ok], pulse[ok]
    m = np.arange(1, tz.size + 1)  # half swing of each beat; odd = tic, even = toc (late)
    heard = tz + np.where(m % 2 == 0, 1e-3 * TOC_LATE_MS, 0.0) + SIGMA_T * rng.standard_normal(tz.size)
    heard = np.round(heard * 48000.0) / 48000.0
    updates = np.arange(FIRST_UPDATE, tz.size + 1, 2)
    updates = updates[tz[updates - 1] <= RECORD_S]
    i = updates - 1  # index of the update's beat
    quarter = 0.25 * math.pi / scene.params["oscillator.omega0"].value
    frac = window_readings(tz, pulse, tz[i - 1] - quarter, tz[i] + quarter)
    amp = TimegrapherObservation.amp_sample(LIFT_DEG * frac, SIGMA_DEG, 1.0, (0.0, 1e9), rng)
    nominal = 3600.0 / BPH
    rate = 86400.0 * (2 * nominal / (heard[i] - heard[i - 2]) - 1.0)
    beat_error = 1e3 * ((heard[i] - heard[i - 1]) - (heard[i - 1] - heard[i - 2])) / 2.0
    invalid = np.zeros(i.size, bool)
    invalid[0] = True
    invalid[rng.choice(np.arange(5, i.size - 2), INVALID_LATER, replace=False)] = True
    rows = ["Time,Rate (s/d),Amplitude (deg),Beat error (ms),BPH,Valid"]
    for k in range(i.size):
        if invalid[k]:  # lost lock: the app shows junk and says so
            r, a, b = rng.uniform(-900, 900), int(rng.integers(0, 400)), rng.uniform(-9, 9)
            rows.append(f"{clock(RELEASE_CLOCK_S + heard[i[k]])},{r:+.1f},{a},{b:+.1f},{BPH},false")
        else:
            rows.append(f"{clock(RELEASE_CLOCK_S + heard[i[k]])},{rate[k]:+.1f},{amp[k]:.0f},{beat_error[k]:+.1f},"
                        f"{BPH},true")
    return rows


def main() -> None:
    scene = escfit.load_scene(SCENE)
    rows = make_rows(scene, np.random.default_rng(SEED))
    settings = [
        "TimeGrapher log export",
        "App,escfit example (datasets/recordings/make_tg_applog.py)",
        f"Generated from,timegrapher_scene.toml: C=0.6 R=100 X=1500; seed {SEED}; amplitude noise {SIGMA_DEG} deg; "
        f"beat noise {1e3 * SIGMA_T:g} ms; tocs {TOC_LATE_MS} ms late",
        "Date,2024-05-03",
        "Model,Monday-like unit",
        "Position,DU",
        f"Lift angle,{LIFT_DEG:g}",
        f"BPH,{BPH}",
        f"Release,{clock(RELEASE_CLOCK_S)}",
        "",
    ]
    last = rows[-1]
    text = "\n".join(settings + rows[:-1]) + "\n" + last[: last.index(",", last.index(",") + 1) + 3]
    OUT.write_text(text)
    print(f"{OUT.name}: {len(rows) - 1} rows, {OUT.stat().st_size / 1024:.1f} KB")


if __name__ == "__main__":
    main()
