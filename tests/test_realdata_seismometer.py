"""A lab seismometer's DataStudio export (datasets/real/seismometer_datastudio, MIT), read as
downloaded: a slow (about 14.5 s), strongly damped swing sampled at 10 Hz, whose first
extrema lie next to the start of the record.  References are the turning points counted by eye
on the file (15 above the noise, from +0.213 V at 0.8 s to +0.026 V at 101 s) and the course's
own figures (period about 14-15 s; DataStudio's envelope exponent 0.0334 1/s, which with an
offset in the envelope is not the viscous rate itself: C = 2 x 0.0334 = 0.067 1/s and Q = 9,
C = omega0 / Q = 0.049 1/s, bracket it).
"""

from __future__ import annotations

import re

from escfit.inference import fit

from .conftest import DATASETS

HERE = DATASETS / "real" / "seismometer_datastudio"

SCENE = """model = "balance"
[oscillator]
omega0 = { value = 0.44, vary = true, min = 0.3, max = 1.0 }
[effects.viscous]
C = { value = 0.05, vary = true, min = 0, max = 1 }
[effects.coulomb]
R = { value = 0.0001, vary = true, min = 0, max = 0.05 }
[recording]
time_column = 1
angle_column = 2
angle_unit = "rad"
"""


def test_a_slow_strongly_damped_seismometer_record_is_read_and_fitted(tmp_path):
    scene = tmp_path / "seismometer.toml"
    scene.write_text(SCENE)
    res = fit(scene, str(HERE / "blow_2_5.txt"))
    count = next(n for n in res.notes if "turning points after the reference" in n)
    n_turns = int(re.match(r"(\d+) turning points", count).group(1))
    period = float(re.search(r"period ([\d.]+) s", count).group(1))
    assert 14 <= n_turns + 1 <= 17, count  # 15 by eye, the reference one included
    assert 13.9 <= period <= 15.1, count
    c = res.summary()["viscous.C"]
    assert 0.049 * 0.8 <= c["estimate"] <= 0.067 * 1.2, c
