"""Reports of saved fits: self-contained HTML (figures embedded) or Markdown.

Reports read the results file only; matplotlib is imported here, when a report is made.
"""

from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path

import numpy as np

from .core.atomic import atomic_path
from .results import FitResult, load_fit

__all__ = ["make_report", "parameter_table"]


def _fmt(v, digits: int = 5) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{v:.{digits}g}" if isinstance(v, float) else str(v)


def parameter_table(res: FitResult) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the parameter table."""
    head = ["parameter", "unit", "median", "68% interval", "95% interval", "R-hat", "ESS (bulk)"]
    rows = []
    for name, r in res.summary().items():
        rows.append([name, r["unit"] or "1", _fmt(r["median"]), f"[{_fmt(r['lo68'])}, {_fmt(r['hi68'])}]",
                     f"[{_fmt(r['lo95'])}, {_fmt(r['hi95'])}]", _fmt(r.get("rhat"), 4), _fmt(r.get("ess_bulk"), 4)])
    return head, rows


def _figures(res: FitResult) -> dict[str, bytes]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figs: dict[str, bytes] = {}
    if "expected" in res.group("least_squares"):
        kind = res.attrs.get("data_kind", "amplitude")
        if kind == "timeseries":
            figs["data and fit"] = _waveform_figure(res, plt)
        else:
            figs["data and fit"] = (_data_figure if kind in ("amplitude", "notches") else _residual_figure)(res, plt)
    post = res.group("posterior")
    if post is not None:
        figs["corner plot"] = _corner(res, post, plt)
    return figs


def _data_figure(res: FitResult, plt) -> bytes:
    obs = res.group("observed_data")
    lsq = res.group("least_squares")
    pp = res.group("posterior_predictive")
    kind = res.attrs.get("data_kind", "amplitude")
    y = obs["reading"].values.astype(float)
    swing = obs["swing"].values
    curves = obs["curve"].values
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    for label in dict.fromkeys(curves):
        m = curves == label
        if pp is not None:
            e = pp["expected"].values.reshape(-1, y.size)[:, m]
            e = e[np.all(np.isfinite(e), axis=1)]
            if e.size:
                lo, med, hi = np.quantile(e, [0.025, 0.5, 0.975], axis=0)
                ax.fill_between(swing[m], lo, hi, alpha=0.3, label=f"95% posterior band {label}")
                ax.plot(swing[m], med, "-", lw=1)
        ax.plot(swing[m], lsq["expected"].values[m], "--", lw=1, label=f"least squares {label}")
        yy = y[m] if kind == "amplitude" else None
        if yy is not None:
            ax.plot(swing[m], yy, "o", ms=4, label=f"data {label}")
            axr.plot(swing[m], yy - lsq["expected"].values[m], "o", ms=4)
    if kind == "notches":
        scene_notch = _notch_from_scene(res)
        for label in dict.fromkeys(curves):
            m = curves == label
            ax.errorbar(swing[m], (y[m] + 0.5) * scene_notch, yerr=0.5 * scene_notch, fmt="o", ms=4,
                        label=f"notch readings {label}")
            axr.plot(swing[m], (y[m] + 0.5) * scene_notch - lsq["expected"].values[m], "o", ms=4)
    ax.set_ylabel("amplitude reading (rad)")
    ax.legend(fontsize=7)
    axr.axhline(0, color="k", lw=0.5)
    axr.set_xlabel("half swing")
    axr.set_ylabel("residual (rad)")
    return _png(fig, plt)


def _waveform_figure(res: FitResult, plt) -> bytes:
    """Every sample against time with the model's theta(t), and the residuals below (deg)."""
    obs = res.group("observed_data")
    lsq_exp = res.group("least_squares")["expected"].values
    pp = res.group("posterior_predictive")
    t = obs["time"].values
    k = 180.0 / np.pi
    y = obs["reading"].values.astype(float)
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    ms = 3 if y.size < 500 else 1.2
    ax.plot(t, k * y, "o", ms=ms, color="0.45", label="recording (every sample fitted)")
    ax.plot(t, k * lsq_exp, "-", lw=1, color="C3", label="model at the least-squares fit")
    if pp is not None:
        e = pp["expected"].values.reshape(-1, y.size)
        e = e[np.all(np.isfinite(e), axis=1)]
        if e.size:
            lo, hi = np.quantile(e - lsq_exp, [0.025, 0.975], axis=0)
            axr.fill_between(t, k * lo, k * hi, alpha=0.3, color="C3", label="95 % posterior band of the model")
    axr.plot(t, k * (y - lsq_exp), "o", ms=ms, color="C0", label="recording - model")
    axr.axhline(0, color="k", lw=0.5)
    ax.set_ylabel("angle reading (deg)")
    axr.set_ylabel("residual (deg)")
    axr.set_xlabel("time on the recording's clock (s)")
    ax.legend(fontsize=8, loc="upper right")
    axr.legend(fontsize=8, loc="upper right")
    return _png(fig, plt)


def _residual_figure(res: FitResult, plt) -> bytes:
    """Recordings whose readings are times or instrument values: residuals per reading series.

    Passage times and beat times grow through the run, so the informative picture is the data
    minus the least-squares prediction, with the posterior band of the prediction around it.
    """
    obs = res.group("observed_data")
    lsq_exp = res.group("least_squares")["expected"].values
    pp = res.group("posterior_predictive")
    y = obs["reading"].values.astype(float)
    swing, curves = obs["swing"].values, obs["curve"].values
    units = obs["reading"].attrs.get("units", "")
    labels = list(dict.fromkeys(curves))
    fig, axes = plt.subplots(len(labels), 1, figsize=(8, 2.8 * len(labels) + 0.8), squeeze=False)
    for ax, label in zip(axes[:, 0], labels):
        m = curves == label
        if pp is not None:
            e = pp["expected"].values.reshape(-1, y.size)[:, m]
            e = e[np.all(np.isfinite(e), axis=1)]
            if e.size:
                lo, hi = np.quantile(e - lsq_exp[m], [0.025, 0.975], axis=0)
                ax.fill_between(swing[m], lo, hi, alpha=0.3, step="mid", label="95% posterior band of the prediction")
        ax.plot(swing[m], y[m] - lsq_exp[m], ".", ms=3, label="data")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel(f"{label}: data - fit")
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel("half swing")
    fig.suptitle(f"residuals against the least-squares prediction (readings in {units})", fontsize=9)
    return _png(fig, plt)


def _corner(res: FitResult, post, plt) -> bytes:
    names = [n for n in res.parameter_names if n in post]
    k = len(names)
    fig, axes = plt.subplots(k, k, figsize=(2.2 * k + 1, 2.2 * k + 1), squeeze=False)
    flat = {n: post[n].values.ravel() for n in names}
    step = max(1, next(iter(flat.values())).size // 3000)
    for i, a in enumerate(names):
        for j, b in enumerate(names):
            axx = axes[i, j]
            if j > i:
                axx.axis("off")
            elif i == j:
                axx.hist(flat[a], bins=40, color="C0")
            else:
                axx.plot(flat[b][::step], flat[a][::step], ".", ms=1, alpha=0.3)
            if i == k - 1:
                axx.set_xlabel(b, fontsize=7)
            if j == 0 and i > 0:
                axx.set_ylabel(a, fontsize=7)
            axx.tick_params(labelsize=6)
    fig.suptitle("posterior (corner plot)")
    return _png(fig, plt)


def _notch_from_scene(res: FitResult) -> float:
    import tomllib

    doc = tomllib.loads(res.attrs["scene"])
    nd = doc.get("observation", {}).get("notch_deg", 6.0)
    return math.radians(float(nd))


def _png(fig, plt) -> bytes:
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


def make_report(path: str | Path, out: str | Path, *, fmt: str = "html", force: bool = False) -> Path:
    """Write a report of the fit stored at ``path``.

    Parameters
    ----------
    fmt
        ``"html"`` (self-contained, images embedded) or ``"md"`` (images written beside it).
    """
    res = load_fit(path)
    a = res.attrs
    head, rows = parameter_table(res)
    warnings = res.warnings
    notes = res.notes
    lsq = res.group("least_squares")
    prov = [("results file", str(path)), ("method", a.get("method")), ("scene file", a.get("scene_file")),
            ("switching", a.get("switching")), ("data file", a.get("data_file")), ("data SHA-256", a.get("data_sha256")),
            ("solver", f"{a.get('solver')} {a.get('solver_options')}"), ("seed", a.get("seed")),
            ("walkers x steps (burn)", f"{a.get('walkers', '-')} x {a.get('steps', '-')} ({a.get('burn', '-')})"),
            ("started / finished", f"{a.get('started')} / {a.get('finished')}"), ("schema", a.get("schema_version")),
            ("versions", a.get("versions")), ("failed evaluations", a.get("failures"))]
    la = lsq.attrs
    fit_stats = f"model {a.get('model', 'balance')}; least squares: chi-square {_fmt(la.get('chisqr'))}, n = {la.get('n_data')}"
    if "redchi" in la:
        units = res.group("observed_data")["reading"].attrs.get("units", "rad") if res.group("observed_data") else "rad"
        sigma_unit = "rad" if units == "notches" else units  # notch counts: the jitter is an angle
        scatter = "" if " and " in units else f", reading scatter {_fmt(la['sigma_hat'])} {sigma_unit}"
        fit_stats += (f", reduced chi-square {_fmt(la['redchi'])}{scatter}, "
                      f"AIC {_fmt(la['aic'])}, BIC {_fmt(la['bic'])}")
    figs = _figures(res)
    out = Path(out)
    if fmt == "md":
        lines = [f"# escfit fit report: {Path(a.get('data_file', '')).name}", "", fit_stats, "", "## Parameters", "",
                 "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(r) + " |" for r in rows]
        lines += ["", "## Warnings: identifiability, convergence and misfit", ""]
        lines += [f"- {w}" for w in warnings] or ["- no warnings"]
        if notes:
            lines += ["", "## What was done to the recording", ""] + [f"- {n}" for n in notes]
        for title, png in figs.items():
            img = out.with_name(f"{out.stem}_{title.replace(' ', '_')}.png")
            with atomic_path(img, force=force) as tmp:
                tmp.write_bytes(png)
            lines += ["", f"## {title.capitalize()}", "", f"![{title}]({img.name})"]
        lines += ["", "## Provenance", ""] + [f"- {k}: `{v}`" for k, v in prov]
        lines += ["", "## Scene", "", "```toml", a.get("scene", ""), "```"]
        text = "\n".join(lines) + "\n"
    else:
        esc = html.escape
        parts = ["<!doctype html><html><head><meta charset='utf-8'><title>escfit fit report</title>",
                 "<style>body{font-family:sans-serif;max-width:1000px;margin:2em auto}table{border-collapse:collapse}"
                 "td,th{border:1px solid #aaa;padding:3px 8px;font-size:13px}.warn{color:#a40}"
                 "pre{background:#f4f4f4;padding:8px;font-size:12px}</style></head><body>",
                 f"<h1>escfit fit report: {esc(Path(a.get('data_file', '')).name)}</h1>", f"<p>{esc(fit_stats)}</p>",
                 "<h2>Parameters</h2><table><tr>" + "".join(f"<th>{esc(h)}</th>" for h in head) + "</tr>"]
        parts += ["<tr>" + "".join(f"<td>{esc(c)}</td>" for c in r) + "</tr>" for r in rows]
        parts += ["</table><h2>Warnings: identifiability, convergence and misfit</h2><ul>"]
        parts += [f"<li class='warn'>{esc(w)}</li>" for w in warnings] or ["<li>no warnings</li>"]
        parts += ["</ul>"]
        if notes:
            parts += ["<h2>What was done to the recording</h2><ul>"] + [f"<li>{esc(n)}</li>" for n in notes]
            parts += ["</ul>"]
        for title, png in figs.items():
            b64 = base64.b64encode(png).decode()
            parts += [f"<h2>{esc(title.capitalize())}</h2><img alt='{esc(title)}' src='data:image/png;base64,{b64}'>"]
        parts += ["<h2>Provenance</h2><table>"] + [f"<tr><td>{esc(k)}</td><td>{esc(str(v))}</td></tr>" for k, v in prov]
        parts += ["</table><h2>Scene</h2><pre>" + esc(a.get("scene", "")) + "</pre></body></html>"]
        text = "".join(parts)
    with atomic_path(out, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out
