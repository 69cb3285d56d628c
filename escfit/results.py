"""Fit results: one HDF5 file per fit, in xarray's netCDF-4 encoding and ArviZ's layout.

Groups
------
``posterior`` (chain, draw), ``sample_stats`` (lp), ``observed_data`` (the readings),
``posterior_predictive`` (noise-free expected readings for a thinned set of draws),
``log_likelihood`` (pointwise, on the same thinned draws, for PSIS-LOO),
``least_squares`` (values, standard errors, correlation, bounds ``min``/``max``, the
``at_bound`` flag and bounded intervals ``lo68``/``hi68``/``lo95``/``hi95``), ``diagnostics`` (autocorrelation
time, split R-hat and ESS per parameter, acceptance per walker).  Root attributes carry the
provenance: scene text, data file and its SHA-256, seed, solver and options, versions of
escfit and its dependencies, timestamps and :data:`SCHEMA_VERSION`.

Read back with :func:`load_fit`; ``arviz.from_netcdf`` and ``xarray.open_datatree`` read the
same file.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .core.errors import ResultsError
from .core.h5write import write_netcdf
from .core.inputs import check_input_file
from .core.plain_tree import Tree

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["SCHEMA_VERSION", "FitResult", "load_fit", "write_fit", "check_results_file"]

SCHEMA_VERSION = "escfit-fit/1"


class FitResult:
    """A fit read from (or about to be written to) a results file.

    ``tree`` is the :class:`xarray.DataTree` of the file's groups.  A fit just run holds them as
    a :class:`~escfit.core.plain_tree.Tree` (numpy arrays) and makes the DataTree on first use of
    ``tree`` or :meth:`group`, so that fitting, writing and printing never import xarray; the
    attributes, the summary and the file written are the same either way.

    ``timings`` holds the seconds each phase of the fit took in this process (empty for a
    fit read from a file, whose ``attrs["timings"]`` keeps them without the write).
    """

    def __init__(self, tree: "xr.DataTree | Tree", path: str = "", timings: dict | None = None):
        self._plain = tree if isinstance(tree, Tree) else None
        self._tree = None if isinstance(tree, Tree) else tree
        self.path = path
        self.timings = dict(timings or {})

    @property
    def tree(self) -> "xr.DataTree":
        if self._tree is None:  # from here on the DataTree is the result (callers may change it)
            self._tree, self._plain = self._plain.to_xarray(), None
        return self._tree

    @tree.setter
    def tree(self, value: "xr.DataTree") -> None:
        self._tree, self._plain = value, None

    def contents(self) -> "xr.DataTree | Tree":
        """What is written: the plain tree of a fit just run, or the DataTree once it was made."""
        return self._plain if self._plain is not None else self._tree

    @property
    def _attrs(self):
        return self.contents().attrs

    @property
    def attrs(self) -> dict[str, Any]:
        return dict(self._attrs)

    def group(self, name: str) -> xr.Dataset | None:
        return self.tree[name].to_dataset() if name in self.tree.children else None

    def arrays(self, name: str):
        """Group ``name`` as the plain tree or the DataTree holds it, or None.

        Both give ``[var].values`` (and ``.dims``, ``.attrs``, ``.shape``, ``.size``), ``name in``,
        ``.coords``, ``.sizes`` and ``.attrs``: what the report, the summary and the figures read, so
        that a fit just run is reported without importing xarray."""
        if self._plain is not None:
            return self._plain.children.get(name)
        return self.group(name)

    @property
    def warnings(self) -> list[str]:
        """Identifiability and convergence warnings recorded with the fit."""
        return json.loads(self._attrs.get("warnings", "[]"))

    @property
    def notes(self) -> list[str]:
        """What was done to the recording before fitting (re-timing, windows, release, stops)."""
        return json.loads(self._attrs.get("notes", "[]") or "[]")

    @property
    def verdict(self) -> str:
        """What the fit determines: ``"determined"``, ``"partly determined"`` or ``"not determined"``
        (see :func:`escfit.inference.reconcile.verdict`; ``""`` in files written before it existed)."""
        return str(self._attrs.get("verdict", ""))

    @property
    def undetermined(self) -> list[str]:
        """Structural parameters the fit does not determine."""
        return json.loads(self._attrs.get("undetermined", "[]") or "[]")

    @property
    def misfit(self) -> dict[str, float]:
        """Residual-structure figures at the best fit (see :mod:`escfit.inference.misfit`)."""
        return json.loads(self._attrs.get("misfit", "{}") or "{}")

    @property
    def parameter_names(self) -> list[str]:
        return json.loads(self._attrs["parameters"])

    @property
    def derived_names(self) -> list[str]:
        """Quantities computed from the parameters at every posterior draw (e.g. Monday's K)."""
        return json.loads(self._attrs.get("derived", "[]") or "[]")

    def summary(self) -> dict[str, dict[str, Any]]:
        """One row per parameter (and derived quantity) for tables and reports.

        Every row holds ``unit``, ``estimate`` (the value to show), ``estimate_kind``
        (``"median"`` for a posterior row, ``"best fit"`` for a least-squares row),
        ``at_bound`` (``None``, ``"min"`` or ``"max"``: the least-squares estimate sits on that
        bound of the scene's range, so its interval is one-sided) and the 68 % and 95 %
        intervals ``lo68``, ``hi68``, ``lo95``, ``hi95``, inside the bounds.

        Posterior rows (emcee fits) add ``median`` (= ``estimate``; the intervals are
        posterior quantiles), ``mean``, ``sd`` and, for sampled parameters, ``rhat``,
        ``ess_bulk``, ``ess_tail`` and ``tau``.  Least-squares rows (no posterior) add
        ``best_fit`` (= ``estimate``) and ``stderr`` and have no ``median``: a best fit is not
        a median.  Their intervals are the ones stored with the fit (see
        :func:`escfit.inference.lsq.bounded_interval`); files written before those were
        stored get ``best_fit +- 1`` and ``+- 1.96`` standard errors, clipped to the bounds
        when the file holds them.
        """
        post = self.arrays("posterior")
        lsq = self.arrays("least_squares")
        diag = self.arrays("diagnostics")
        units = json.loads(self._attrs.get("units", "{}"))
        lsq_index = _index(lsq)
        diag_index = _index(diag) if diag is not None and "rhat" in diag else {}
        out: dict[str, dict[str, Any]] = {}
        for name in self.parameter_names + [n for n in self.derived_names if n not in self.parameter_names]:
            row: dict[str, Any] = {"unit": units.get(name, "")}
            at_bound = _at_bound(lsq, lsq_index[name]) if name in lsq_index else None
            if post is not None and name in post:
                x = np.asarray(post[name].values).ravel()
                q = np.quantile(x, [0.025, 0.16, 0.5, 0.84, 0.975])
                row.update(estimate=float(q[2]), estimate_kind="median", at_bound=at_bound, median=float(q[2]),
                           lo68=float(q[1]), hi68=float(q[3]), lo95=float(q[0]), hi95=float(q[4]),
                           mean=float(x.mean()), sd=float(x.std(ddof=1)))
                if name in diag_index:
                    i = diag_index[name]
                    row.update({k: float(diag[k].values[i]) for k in ("rhat", "ess_bulk", "ess_tail", "tau")})
            elif name in lsq_index:
                i = lsq_index[name]
                v, se = float(lsq["value"].values[i]), float(lsq["stderr"].values[i])
                row.update(estimate=v, estimate_kind="best fit", at_bound=at_bound, best_fit=v, stderr=se,
                           **_lsq_intervals(lsq, i, v, se))
            else:
                continue
            out[name] = row
        return out


def _index(group) -> dict[str, int]:
    """Position of each parameter along a group's ``parameter`` dimension (empty without the group)."""
    return {} if group is None else {str(n): i for i, n in enumerate(np.asarray(group["parameter"].values))}


def _at_bound(lsq, i: int) -> str | None:
    """``"min"``/``"max"`` from the stored least-squares flag of parameter ``i`` (``None`` in files without it)."""
    if "at_bound" not in lsq:
        return None
    flag = int(lsq["at_bound"].values[i])
    return "min" if flag < 0 else ("max" if flag > 0 else None)


def _lsq_intervals(lsq, i: int, value: float, stderr: float) -> dict[str, float]:
    """The stored bounded intervals of parameter ``i``, or (older files) the symmetric ones clipped
    to any stored bounds."""
    keys = ("lo68", "hi68", "lo95", "hi95")
    if all(k in lsq for k in keys):
        return {k: float(lsq[k].values[i]) for k in keys}
    lower = float(lsq["min"].values[i]) if "min" in lsq else -math.inf
    upper = float(lsq["max"].values[i]) if "max" in lsq else math.inf
    out = {}
    for level, z in (("68", 1.0), ("95", 1.96)):
        lo, hi = value - z * stderr, value + z * stderr
        out[f"lo{level}"] = float(min(max(lo, lower), upper)) if math.isfinite(lo) else lo
        out[f"hi{level}"] = float(max(min(hi, upper), lower)) if math.isfinite(hi) else hi
    return out


def load_fit(path: str | Path) -> FitResult:
    """Read a results file written by :func:`escfit.fit`.

    Its layout is checked first, from the file's metadata alone (:func:`check_results_file`),
    so that a damaged, incomplete or inflated file is refused before its arrays are read.

    Raises
    ------
    ResultsError
        Missing file (or not a regular file), not an escfit results file, an unknown schema
        version, or a file whose layout :func:`check_results_file` refuses.
    """
    import warnings

    import xarray as xr

    p = Path(path)
    check_input_file(p, "results", ResultsError)
    check_results_file(p)
    try:
        with warnings.catch_warnings():  # a reader's remarks on a file already checked are not the user's business
            warnings.simplefilter("ignore")
            with xr.open_datatree(p, engine="h5netcdf") as opened:  # read into memory, then let go of the file
                tree = opened.load()
    except Exception as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ResultsError(f"damaged or unreadable results file ({first[:160]})", str(path)) from None
    return FitResult(tree, str(path))


# Root attributes holding JSON, with the kind of value each must hold
JSON_ATTRS = {"parameters": list, "derived": list, "warnings": list, "notes": list, "undetermined": list,
              "units": dict, "meanings": dict, "misfit": dict, "held": dict, "failures": dict}
# The arrays a group must hold when it is there, and the dimension its data arrays run along
GROUP_ARRAYS = {"least_squares": (("value", "stderr"), ("parameter",)),
                "sample_stats": (("lp",), ("chain", "draw")),
                "diagnostics": (("rhat", "ess_bulk", "ess_tail", "tau"), ("parameter",))}
# The groups every emcee fit has
SAMPLED = ("posterior", "sample_stats", "diagnostics")


def check_results_file(path: str | Path) -> None:
    """Refuse a results file whose layout no fit of escfit writes, reading its metadata only.

    Checked, in this order, before any array is read: an HDF5 file of :data:`SCHEMA_VERSION`;
    arrays that declare no more than the file holds and agree with their dimensions
    (:mod:`escfit.core.h5layout`); root attributes that hold the JSON they should
    (:data:`JSON_ATTRS`), among them a non-empty list of parameters; a ``least_squares``
    group, and for an emcee fit its ``posterior``, ``sample_stats`` and ``diagnostics``
    (:data:`SAMPLED`); the arrays each group must hold along their dimensions
    (:data:`GROUP_ARRAYS`); every parameter and derived quantity in the posterior along
    (chain, draw), with as many chains and draws as the log-probabilities (when they are there).

    Raises
    ------
    ResultsError
        Naming the file and the first thing that is wrong.
    """
    import h5py

    from .core import h5layout

    if not h5py.is_hdf5(path):
        raise ResultsError("not an HDF5 file: give a results file written by escfit fit", str(path))
    layout = h5layout.read_layout(path, "damaged or unreadable results file")
    schema = layout.attrs.get("schema_version")
    if schema != SCHEMA_VERSION:
        raise ResultsError(f"not an escfit fit file of schema {SCHEMA_VERSION!r} (found {schema!r})", str(path))
    h5layout.check_backed(layout)
    h5layout.check_dimensions(layout)
    names = [*_json_attr(layout, "parameters"), *_json_attr(layout, "derived")]
    for key in JSON_ATTRS:
        _json_attr(layout, key)
    _check_groups(layout, names)


def _json_attr(layout, key: str) -> Any:
    """Root attribute ``key`` decoded (its empty value when absent), or a refusal naming it."""
    kind = JSON_ATTRS[key]
    raw = layout.attrs.get(key, "")
    if key == "parameters" and raw == "":
        raise ResultsError("incomplete results file: the root attribute 'parameters' is missing", layout.where)
    try:
        value = json.loads(raw) if raw != "" else kind()
    except (TypeError, ValueError):
        value = None
    if not isinstance(value, kind) or (kind is list and not all(isinstance(v, str) for v in value)) \
            or (key == "parameters" and not value):
        raise ResultsError(f"damaged results file: the root attribute {key!r} is not a JSON "
                           f"{'list of names' if kind is list else 'object'} ({str(raw)[:40]!r})", layout.where)
    return value


def _check_groups(layout, names: list[str]) -> None:
    """The groups a fit has, the arrays they hold and the posterior's parameters (see
    :func:`check_results_file`)."""
    from .core.h5layout import expect_arrays, expect_dims

    missing = ["least_squares"] if "least_squares" not in layout.groups else []
    if layout.attrs.get("method") == "emcee":
        missing += [g for g in SAMPLED if g not in layout.groups]
    if missing:
        raise ResultsError(f"incomplete results file: its {missing[0]} group is missing", layout.where)
    for group, (arrays, dims) in GROUP_ARRAYS.items():
        if group in layout.groups:
            expect_arrays(layout, group, arrays)
            for name in arrays:
                expect_dims(layout, f"{group}/{name}", dims)
    if "posterior" not in layout.groups:
        return
    expect_arrays(layout, "posterior", names, " (a parameter of the fit)")
    for name in names:
        expect_dims(layout, f"posterior/{name}", ("chain", "draw"))
    if "sample_stats" not in layout.groups:
        return
    post, stats = layout.arrays[f"posterior/{names[0]}"].shape, layout.arrays["sample_stats/lp"].shape
    if post != stats:
        raise ResultsError(f"inconsistent results file: the posterior holds {post[0]} chains x {post[1]} draws, "
                           f"sample_stats/lp {stats[0]} x {stats[1]}", layout.where)


def write_fit(result: FitResult, path: str | Path, *, force: bool = False) -> None:
    """Write atomically; an existing file is replaced only with ``force``.

    Data variables carry HDF5 Fletcher-32 checksums, so a damaged file is refused on reading
    (:func:`load_fit`) instead of giving changed numbers; the file is built in memory first, so
    a full disk is one clear error and leaves nothing behind (:mod:`escfit.core.h5write`).
    """
    write_netcdf(result.contents(), path, force=force)
    result.path = str(path)


def clean_attrs(attrs: dict[str, Any]) -> dict[str, Any]:
    """netCDF-safe attributes: None -> '', dict/list -> JSON, bool -> int."""
    out = {}
    for k, v in attrs.items():
        if isinstance(v, np.generic):
            v = v.item()
        if v is None:
            v = ""
        elif isinstance(v, bool):
            v = int(v)
        elif isinstance(v, (dict, list, tuple)):
            v = json.dumps(v, default=float)
        elif isinstance(v, float) and not math.isfinite(v):
            v = str(v)
        out[k] = v
    return out
