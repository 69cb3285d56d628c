"""Monday's 1965 friction table, and rig sessions reconstructed from it.

The thesis prints only the friction coefficients (ruby pallet at 2.2 g on three plates),
not the rig readings behind them.  To exercise the whole chain (readings -> geometry ->
posterior) on his numbers, each material gets a synthetic session whose readings are
consistent with the printed coefficient under stated assumptions
(:data:`ASSUMPTIONS`).  The reconstruction is deterministic: seeds are fixed and the
committed CSV files under ``datasets/friction`` can be regenerated bit for bit with
:func:`write_sessions`.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

from ..core.csvtable import refuses_unreadable
from ..core.errors import DataError
from ..core.units import registry
from .readers import Readings, write_readings
from .scene import RigScene, parse
from .synthetic import SessionSpec, make_session

__all__ = ["MuRow", "read_mu_table", "ASSUMPTIONS", "session_spec", "sessions", "write_sessions",
           "SCENE_TEXT", "scene", "session_file"]

_GF = float(registry().Quantity(1.0, "gf").to("N").magnitude)
_INCH = 0.0254
_FT_S = 0.3048

#: Generating assumptions of the reconstructed sessions (none of these numbers is printed
#: in the thesis except the 2.2 g load, the 3-10 ft/s speed range and the reading of the
#: light spot to 1/2 inch on the 11.5 ft scale).
ASSUMPTIONS = {
    "k_inch": 2.0,            # wire to contact point, measured to +-0.01 inch (1 sd)
    "d_inch": 1.0,            # wire height above the disc, measured to +-0.01 inch (1 sd)
    "geometry_sd_inch": 0.01,
    "true_geometry": "nominal",  # the session's true k, d equal the measured ones
    "loads_gf": (1.2, 1.7, 2.2, 2.7, 3.2),     # symmetric about the table's 2.2 g
    "speeds_ft_s": (3.0, 5.0, 7.5, 10.0),      # Monday's 3-10 ft/s, every load at every speed
    "mu_v": 0.0,                               # no variation with speed (Monday's finding)
    "mu_w_relative_per_gf": -0.06,             # 'slight change' with load: -6 % of mu per gram
    "resolution_inch": 0.5,                    # spot read to 1/2 inch ...
    "scale_length_ft": 11.5,                   # ... on the 11.5 ft scale, which the
    "full_scale_load_gf": 5.0,                 # calibration spans for 0 to 5 g
    "settings_per_reading": 2,                 # calibration setting + sliding setting
    "round_dw_gf": 1e-4,                       # readings written to 0.1 mg
    "seed_base": 1965,                         # seed = 1965 + row index in the table
    "centre_noise": True,                      # plain mean of per-reading mu = printed mu
}

#: Scene used to fit the reconstructed sessions (also in datasets/friction/monday1965_rig.toml).
SCENE_TEXT = """\
# Rig scene for the sessions reconstructed from Monday (1965), Chapter VI.
# Geometry and calibration are assumptions (see docs/friction.md); the thesis prints neither.
model = "friction_rig"

[rig]
k = { value = "2.0 inch", sd = "0.01 inch" }   # torsion wire to the pallet's contact point
d = { value = "1.0 inch", sd = "0.01 inch" }   # torsion wire height above the disc
load_at = "reading"                            # load column = normal force while sliding

[friction]
mu = { value = 0.12, vary = true, min = 0.0, max = 1.0 }             # at 2.2 gf and 6.5 ft/s
mu_w = { value = 0.0, vary = true, prior = "normal(0, 0.02 / gf)" }  # change per gram of load
load_ref = "2.2 gf"
mu_v = { value = 0.0, vary = true, prior = "normal(0, 0.005 s/ft)" } # change per ft/s
speed_ref = "6.5 ft/s"

[observation]               # reading noise observation.sigma from the spot resolution
resolution = "0.5 inch"     # light spot read to 1/2 inch
full_scale_load = "5 gf"    # assumed: the calibration spans the scale for 0 to 5 g
scale_length = "11.5 ft"
"""


@dataclass(frozen=True)
class MuRow:
    """One row of Monday's table.

    Attributes
    ----------
    material, pallet
        Plate material and pallet material.
    load
        Normal load, N (2.2 gram-force).
    mu
        Printed friction coefficient.
    handbook
        Handbook range printed beside it (text), or ``""``.
    line
        Line in the CSV file.
    """

    material: str
    pallet: str
    load: float
    mu: float
    handbook: str
    line: int


@refuses_unreadable
def read_mu_table(path: str | Path) -> list[MuRow]:
    """Read ``monday1965_mu.csv`` (``#`` lines are comments).

    Raises
    ------
    DataError
        Missing file or column, or a non-numeric load or mu (naming file:line [column]).
    """
    where = str(path)
    p = Path(path)
    if not p.is_file():
        raise DataError("table file not found", where)
    lines = [(n, line) for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise DataError("empty file: no header and no rows", where)
    header_line, header_text = lines[0]
    header = next(csv.reader([header_text]))
    need = ["material", "pallet", "load_g", "mu", "handbook_steel_on_steel_mu"]
    missing = [c for c in need if c not in header]
    if missing:
        raise DataError(f"missing column(s) {missing}; header has {header}", f"{where}:{header_line}")
    rows = []
    for n, text in lines[1:]:
        cells = dict(zip(header, next(csv.reader(io.StringIO(text)))))
        values = {}
        for col in ("load_g", "mu"):
            try:
                values[col] = float(cells[col])
            except (KeyError, ValueError):
                raise DataError(f"value {cells.get(col)!r} is not a number", f"{where}:{n} [{col}]") from None
        rows.append(MuRow(cells["material"], cells["pallet"], values["load_g"] * _GF, values["mu"],
                          cells["handbook_steel_on_steel_mu"], n))
    return rows


def session_spec(row: MuRow) -> SessionSpec:
    """The generating specification of the session of one table row (SI units)."""
    a = ASSUMPTIONS
    from .rig import load_sd_from_scale

    slope = a["scale_length_ft"] * 12 * _INCH / (a["full_scale_load_gf"] * _GF)
    sd = load_sd_from_scale(a["resolution_inch"] * _INCH, slope, a["settings_per_reading"])
    return SessionSpec(
        mu=row.mu,
        loads=tuple(x * _GF for x in a["loads_gf"]),
        speeds=tuple(x * _FT_S for x in a["speeds_ft_s"]),
        k=a["k_inch"] * _INCH,
        d=a["d_inch"] * _INCH,
        reading_sd=sd,
        mu_w=a["mu_w_relative_per_gf"] * row.mu / _GF,
        mu_v=a["mu_v"],
        load_ref=row.load,
        speed_ref=6.5 * _FT_S,
        centre_noise=a["centre_noise"],
        round_to=a["round_dw_gf"] * _GF,
        material=row.material,
    )


def session_file(row: MuRow) -> str:
    """File name of the reconstructed session of one row."""
    slug = row.material.split(" (")[0].lower().replace(" ", "_")
    return f"monday1965_session_{slug}.csv"


def sessions(table: str | Path) -> dict[str, Readings]:
    """Generate the reconstructed sessions, by material (in memory, not rounded through CSV)."""
    out = {}
    for i, row in enumerate(read_mu_table(table)):
        out[row.material] = make_session(session_spec(row), ASSUMPTIONS["seed_base"] + i,
                                         where=session_file(row))
    return out


def write_sessions(table: str | Path, outdir: str | Path) -> list[Path]:
    """Regenerate the session CSV files and the fitting scene next to the table."""
    outdir = Path(outdir)
    written = []
    rows = read_mu_table(table)
    gen = sessions(table)
    a = ASSUMPTIONS
    for i, row in enumerate(rows):
        path = outdir / session_file(row)
        comments = [
            f"source: synthetic session reconstructed from Monday (1965), Chapter VI, {row.material}: "
            f"printed mu {row.mu:.3f} at {a['loads_gf'][2]} g",
            "generator: escfit.friction.monday.write_sessions (see docs/friction.md)",
            f"seed: {a['seed_base'] + i} (numpy default_rng, standard normal reading errors)",
            f"geometry: k = {a['k_inch']} inch, d = {a['d_inch']} inch (true = nominal)",
            f"law: mu = {row.mu:.3f} * (1 {a['mu_w_relative_per_gf']:+.2f} per gf * (w - 2.2 gf)), no speed term",
            "reading sd: 1/2 inch spot resolution, 5 gf over the 11.5 ft scale, 2 settings per reading",
            "noise: centred so the plain mean of the per-reading mu equals the printed value",
            f"material: {row.material}",
            "",
        ]
        write_readings(gen[row.material], path, comments=comments, unit="g", speed_unit="ft_s", digits=4)
        written.append(path)
    scene_path = outdir / "monday1965_rig.toml"
    scene_path.write_text(SCENE_TEXT, encoding="utf-8")
    written.append(scene_path)
    return written


def scene(where: str = "monday1965_rig.toml") -> RigScene:
    """The fitting scene of the reconstructed sessions."""
    import tomllib

    return parse(tomllib.loads(SCENE_TEXT), where=where, text=SCENE_TEXT)
