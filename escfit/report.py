"""Reports of saved fits: self-contained HTML (figures embedded) or Markdown.

Reports read the results file only; matplotlib is imported here, when a report is made.
"""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path

import numpy as np

from .core.atomic import atomic_path
from .core.figures import png, pyplot
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
    """The family's figures (data against the model), else the generic one, and the corner plot."""
    from .inference.registry import family

    plt = pyplot()
    figs: dict[str, bytes] = {}
    draw = getattr(family(res.attrs.get("model", "balance")), "figures", None)
    if draw is not None:
        figs.update(draw(res))
    if "data and fit" not in figs and "expected" in res.group("least_squares"):
        figs["data and fit"] = _generic_figure(res, plt)
    post = res.group("posterior")
    if post is not None:
        figs["corner plot"] = _corner(res, post, plt)
    return figs


def _generic_figure(res: FitResult, plt) -> bytes:
    """Readings against their plotting coordinate ``x`` (else their index), the model at the
    least-squares optimum and the 95 % posterior band, per curve; residuals below."""
    obs = res.group("observed_data")
    lsq_exp = res.group("least_squares")["expected"].values
    pp = res.group("posterior_predictive")
    y = obs["reading"].values.astype(float)
    units = obs["reading"].attrs.get("units", "")
    if "x" in obs.coords:
        x = obs["x"].values.astype(float)
        xlabel = f"{obs['x'].attrs.get('long_name', 'x')} ({obs['x'].attrs.get('units', '')})"
    else:
        x, xlabel = np.arange(y.size, dtype=float), "reading number"
    curves = obs["curve"].values.astype(str) if "curve" in obs.coords else np.full(y.size, "")
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1.2]})
    for k, label in enumerate(dict.fromkeys(curves)):
        m = curves == label
        order = np.argsort(x[m], kind="stable")
        xs, colour, name = x[m][order], f"C{k % 10}", f" ({label})" if label else ""
        if pp is not None:
            e = pp["expected"].values.reshape(-1, y.size)[:, m][:, order]
            e = e[np.all(np.isfinite(e), axis=1)]
            if e.size:
                lo, hi = np.quantile(e, [0.025, 0.975], axis=0)
                ax.fill_between(xs, lo, hi, alpha=0.25, color=colour, label=f"95 % posterior band{name}")
        ax.plot(xs, lsq_exp[m][order], "-", lw=1.2, color=colour, label=f"model, best fit{name}")
        ax.plot(xs, y[m][order], "o", ms=4, color=colour, mfc="none", label=f"readings{name}")
        axr.plot(xs, (y[m] - lsq_exp[m])[order], "o", ms=4, color=colour, mfc="none")
    axr.axhline(0, color="k", lw=0.5)
    ax.set_ylabel(f"reading ({units})")
    axr.set_ylabel(f"reading - model ({units})")
    axr.set_xlabel(xlabel)
    ax.legend(fontsize=8)
    return png(fig)


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
    return png(fig)


def _fit_stats(res: FitResult, la) -> str:
    """One line on the least-squares fit: what the reading scatter is and where it comes from.

    With a free noise scale the scatter is profiled from the residuals (a reduced chi-square
    would be 1 by construction and is not shown); with the scene's noise known, the reduced
    chi-square says how the residuals compare with it.
    """
    a = res.attrs
    n = int(la.get("n_data", 0) or 0)
    npar = int(res.group("least_squares").sizes.get("parameter", 0))
    units = res.group("observed_data")["reading"].attrs.get("units", "rad") if res.group("observed_data") else "rad"
    sigma_unit = "rad" if units == "notches" else units  # notch counts: the jitter is an angle
    head = f"model {a.get('model', 'balance')}; least squares on {n} reading(s), {npar} fitted parameter(s)"
    if "redchi" not in la:
        return head
    if n <= npar:
        return head + ": as many parameters as readings, the fit is exact and the readings give no scatter estimate"
    mixed = " and " in units
    if int(la.get("noise_profiled", 1) or 0):
        scatter = "" if mixed else f"; reading scatter {_fmt(la['sigma_hat'])} {sigma_unit} (profiled from the residuals)"
        return head + scatter + f"; AIC {_fmt(la['aic'])}, BIC {_fmt(la['bic'])}"
    implied = _fmt(float(la["sigma_hat"]) * math.sqrt(float(la["redchi"]))) if not mixed else None
    return (head + f"; reduced chi-square {_fmt(la['redchi'])} against the scene's reading noise "
            f"{_fmt(la['sigma_hat'])} {sigma_unit}" + (f" (residual scatter {implied} {sigma_unit})" if implied else "")
            + f"; AIC {_fmt(la['aic'])}, BIC {_fmt(la['bic'])}")


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
            ("solver", f"{a.get('solver', '')} {a.get('solver_options', '')}".strip()), ("seed", a.get("seed")),
            ("walkers x steps (burn)", f"{a.get('walkers', '-')} x {a.get('steps', '-')} ({a.get('burn', '-')})"),
            ("started / finished", f"{a.get('started')} / {a.get('finished')}"), ("schema", a.get("schema_version")),
            ("versions", a.get("versions")), ("failed evaluations", a.get("failures"))]
    prov = [(k, v) for k, v in prov if v not in (None, "", "None None")]
    la = lsq.attrs
    fit_stats = _fit_stats(res, la)
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
        for title, image in figs.items():
            img = out.with_name(f"{out.stem}_{title.replace(' ', '_')}.png")
            with atomic_path(img, force=force) as tmp:
                tmp.write_bytes(image)
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
        for title, image in figs.items():
            b64 = base64.b64encode(image).decode()
            parts += [f"<h2>{esc(title.capitalize())}</h2><img alt='{esc(title)}' src='data:image/png;base64,{b64}'>"]
        parts += ["<h2>Provenance</h2><table>"] + [f"<tr><td>{esc(k)}</td><td>{esc(str(v))}</td></tr>" for k, v in prov]
        parts += ["</table><h2>Scene</h2><pre>" + esc(a.get("scene", "")) + "</pre></body></html>"]
        text = "".join(parts)
    with atomic_path(out, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out
