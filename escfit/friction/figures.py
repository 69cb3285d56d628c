"""Report figure of friction-rig fits: the extra load dw against the normal load, per sliding speed.

The rig's readings are the extra load ``dw`` (N) that restores the beam with the disc turning
(see :mod:`escfit.friction.rig`); the model predicts it from mu(load, speed) and the geometry.
Forces are drawn in gram-force, as the rig's weights are, and each sliding speed gets one
colour in both panels.
"""

from __future__ import annotations

import numpy as np

from ..core.figures import fit_figure, png, pyplot

__all__ = ["figures"]

G0 = 9.80665  # m/s^2: one gram-force is G0 / 1000 newton
FT = 0.3048  # m per foot


def figures(res) -> dict[str, bytes]:
    """``{"data and fit": PNG}``: readings, best-fit model and posterior band against the load."""
    lsq = res.group("least_squares")
    obs = res.group("observed_data")
    if lsq is None or "expected" not in lsq or obs is None:
        return {}
    plt = pyplot()
    gf = 1000.0 / G0  # gram-force per newton
    y = obs["reading"].values.astype(float) * gf
    model = lsq["expected"].values.astype(float) * gf
    load = obs["x"].values.astype(float) * gf
    if "speed" in obs.coords:
        speed = obs["speed"].values.astype(float)
        curves = np.array([f"{v:.4g}" for v in speed])
        names = {c: f"{float(c) / FT:.3g} ft/s" for c in dict.fromkeys(curves)}
    else:
        curves = obs["curve"].values.astype(str)
        names = None
    band = None
    pp = res.group("posterior_predictive")
    if pp is not None:
        e = pp["expected"].values.reshape(-1, y.size)
        e = e[np.all(np.isfinite(e), axis=1)]
        if e.size:
            band = tuple(np.quantile(e, [0.025, 0.975], axis=0) * gf)
    material = ", ".join(dict.fromkeys(obs["curve"].values.astype(str))) if "curve" in obs.coords else ""
    fig = fit_figure(plt, x=load, y=y, model=model, curves=curves, band=band, names=names,
                     xlabel="normal load w while sliding (gf)", ylabel="extra load dw restoring the beam (gf)",
                     reading_key="rig readings")
    caption = ("Friction rig" + (f" ({material})" if material else "") + ": the extra load dw needed to bring the "
               "beam back with the disc turning, against the normal load, one colour per sliding speed. Lines: the "
               "model at the least-squares best fit (mu linear in load and speed, rig geometry k and d)"
               + ("; shaded: 95 % band of the model over the posterior draws" if band is not None else "")
               + ". Lower panel: reading minus best fit. Forces in gram-force (1 gf = 9.807 mN).")
    out = {"data and fit": png(fig, caption=caption)}
    if "speed" in obs.coords:
        mu = _mu_figure(res, plt, band)
        if mu is not None:
            out["friction coefficient"] = mu
    return out


def _mu_figure(res, plt, band_gf):
    """Each reading's friction coefficient at the best-fit geometry against sliding speed, per load."""
    import tomllib

    from .rig import mu_from_reading

    lsq, obs = res.group("least_squares"), res.group("observed_data")
    names = list(map(str, lsq["parameter"].values))
    if not {"rig.k", "rig.d"} <= set(names):
        return None
    k, d = (float(lsq["value"].sel(parameter=n)) for n in ("rig.k", "rig.d"))
    load_at = tomllib.loads(res.attrs.get("scene", "") or "").get("rig", {}).get("load_at", "reading")
    w = obs["x"].values.astype(float)
    speed = obs["speed"].values.astype(float) / FT

    def mu(dw):
        return mu_from_reading(w, np.asarray(dw, dtype=float), k, d, load_at)

    gf = 1000.0 / G0
    curves = np.array([f"{v * gf:.3g} gf" for v in w])
    band = None if band_gf is None else tuple(mu(b / gf) for b in band_gf)
    fig = fit_figure(plt, x=speed, y=mu(obs["reading"].values), model=mu(lsq["expected"].values), curves=curves,
                     band=band, xlabel="sliding speed (ft/s)", ylabel="friction coefficient mu",
                     reading_key="mu of each reading", figsize=(9.0, 5.6))
    caption = (f"The friction coefficient mu = F/N of each reading, worked out at the best-fit geometry (k = "
               f"{k / 0.0254:.4g} in, d = {d / 0.0254:.4g} in), against the sliding speed, one colour per normal load; "
               "lines: mu(load, speed) of the least-squares best fit" +
               ("; shaded: the 95 % posterior band of the model's dw, converted at the best-fit geometry" if band is not None else "")
               + ". Lower panel: reading minus best fit.")
    return png(fig, caption=caption)
