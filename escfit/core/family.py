"""Model families: one contract, one registry.

A model family (the balance wheel and pendulum, the Geneva escapement, the verge escapement,
the friction rig, or one of a user's own) is an object implementing :class:`Family`, found by
the scene's ``model =`` name.  Everything the library, the command line, the reports and the
batch code know about a family they ask that object; none of them branches on a family's name.

The built-in families are registered here by the dotted path of their entry (``"<module>:<attr>"``)
and imported only when first asked for, so that ``import escfit`` and ``escfit -h`` stay quick.
Another family is added with :func:`register_family`::

    from escfit.core.family import FamilyBase, register_family

    class Toy(FamilyBase):
        name = "toy"
        ...

    register_family(Toy())

after which ``escfit fit``, ``summary``, ``report`` and ``fit-many`` (in the same process) and
:func:`escfit.fit` take scenes with ``model = "toy"``.  ``tests/test_family_conformance.py``
runs the same checks over every registered family.

A package that ships a family registers it once for every process, dask's workers included, by
an entry point in the group ``escfit.families`` (:data:`ENTRY_POINT_GROUP`) of its metadata::

    [project.entry-points."escfit.families"]
    toy = "toy_package.family:FAMILY"

The entry points are read only when a scene names a family that is not registered, or when the
families are listed, so a run that uses the shipped families never scans the installed
packages.  A built-in name, or one registered in the process, wins over an entry point.

This module sits in the lowest layer: it imports no family, and the types it names from higher
layers (scenes, :class:`~escfit.likelihood.problem.Problem`, results) are only annotations.
"""

from __future__ import annotations

import importlib
from typing import Any, Callable, Mapping, Protocol, runtime_checkable

from .errors import SceneError

__all__ = ["Family", "FamilyBase", "Derived", "register_family", "unregister_family", "get_family",
           "family_names", "BUILTIN_FAMILIES", "check_options", "ENTRY_POINT_GROUP"]

#: the entry-point group in which installed packages name their families (``name = "module:attr"``)
ENTRY_POINT_GROUP = "escfit.families"

#: the families escfit ships: ``model =`` name -> ``"<module>:<attribute>"`` of its entry
BUILTIN_FAMILIES: dict[str, str] = {
    "balance": "escfit.balance.family:FAMILY",
    "geneva": "escfit.geneva.family:FAMILY",
    "verge": "escfit.verge.family:FAMILY",
    "friction_rig": "escfit.friction.family:FAMILY",
}

# name -> the family, or the path of its entry until first use
_REGISTRY: dict[str, "Family | str"] = dict(BUILTIN_FAMILIES)
_FROM_ENTRY_POINTS: dict[str, str] = {}  # name -> "module:attr" of the families installed packages declare
_SCANNED = False  # whether the entry points were read in this process


#: one derived quantity of a fit, for the report: (label, unit shown, values at every draw, formula)
Derived = tuple[str, str, Any, str]


@runtime_checkable
class Family(Protocol):
    """What a model family provides.

    Attributes
    ----------
    name : str
        The scene's ``model =`` value.
    formats : Mapping[str, Callable]
        Recording formats the family reads, name -> reader ``(path) -> recording``.
    fit_defaults : Mapping[str, Any]
        Defaults of the sampler and optimiser where the generic ones do not suit
        (``walkers``, ``steps``, ``max_steps``, ``burn``, ``n_starts``, ``predictive_draws``, ``moves``).
    problem_options : frozenset[str]
        Keyword options :meth:`problem` takes (``solver``, ``fmt``, ``unit``, ``notch_deg``,
        ``recording``, ``material``, ``step`` ...); the command line passes an option only to a
        family that names it here and refuses it for the others (:func:`check_options`).
    recorders : tuple[str, ...]
        Synthetic recorders :meth:`record` can write (``escfit simulate --recorder``); empty: none.
    """

    name: str
    formats: Mapping[str, Callable[..., Any]]
    fit_defaults: Mapping[str, Any]
    problem_options: frozenset[str]
    recorders: tuple[str, ...]

    def parse(self, doc: Mapping[str, Any], where: str, text: str) -> Any:
        """The family's frozen scene object of a parsed TOML document (``text`` is its source)."""

    def simulate(self, scene, solver: str | None = None, **options) -> Any:
        """Run a scene and return an :class:`xarray.Dataset` with its ``status`` in ``attrs``."""

    def json_summary(self, ds) -> dict[str, Any]:
        """The JSON object ``escfit simulate --json`` prints for a run (``status`` included)."""

    def describe(self, ds) -> list[str]:
        """Lines ``escfit simulate`` prints under the run's first line."""

    def detect(self, path) -> str:
        """The format of a recording file (a key of :attr:`formats`), or an escfit error naming the file."""

    def read(self, path, fmt: str | None = None, **options) -> Any:
        """A recording file in one of :attr:`formats` (``fmt``; detected when ``None``)."""

    def problem(self, scene, data, **options) -> Any:
        """The fit problem (:class:`~escfit.likelihood.problem.Problem`) of a scene and a recording
        (object or path), built whole; options not in :attr:`problem_options` refused."""

    def record(self, scene, recorder: str, path, **options) -> None:
        """Write a synthetic recording of ``scene`` with one of :attr:`recorders` to ``path``."""

    def title(self, attrs: Mapping[str, Any]) -> str:
        """The model in plain words for a report, from a saved fit's root attributes (its scene text)."""

    def derived(self, draws: Mapping[str, Any], attrs: Mapping[str, Any]) -> tuple[list[Derived], str]:
        """Quantities people quote, computed at every draw of the parameters (canonical units),
        and a closing sentence; ``([], "")`` when the family derives none."""

    def figures(self, result) -> dict[str, bytes]:
        """PNG figures of a saved fit for the report (``{}`` when the generic ones suffice)."""

    def plain(self, draws: Mapping[str, Any], attrs: Mapping[str, Any], observed=None) -> list[str]:
        """The fit's answer in a few plain sentences (numbers with their 95 % intervals in words,
        :mod:`escfit.core.plainwords`), from the parameter draws, the results' root attributes
        and their ``observed_data`` group (or None)."""

    def splits_units(self, scene) -> bool:
        """Whether ``fit-many`` reads this scene's recording files on the client and splits them
        into units (:meth:`units_of`) instead of fitting each file as one unit."""

    def units_of(self, path, *, notch_deg: float | None = None) -> list[tuple[str, Any]] | None:
        """The units of a recording file as ``(unit name, recording)``, or ``None`` when the file
        is one unit (see :meth:`splits_units`)."""

    def agreement(self, problem, lsq, refit, *, seed: int = 0) -> Any:
        """The fit held against the record it was fitted to (an
        :class:`escfit.analysis.agreement.Agreement`), or ``None`` when the family has no such
        check for this problem; ``refit(problem, start, seed) -> (result, unresolved)`` is least
        squares of another problem of the same record."""


class FamilyBase:
    """Defaults of the optional parts of :class:`Family`, for families to inherit.

    A subclass sets :attr:`name`, :attr:`formats`, :attr:`problem_options` and :attr:`package`
    (or implements :meth:`parse`, :meth:`simulate` and :meth:`json_summary` itself), and
    implements :meth:`detect` and :meth:`problem`.
    """

    name: str = ""
    #: the package whose ``parse(doc, where=, text=)``, ``simulate(scene, solver, **options)`` and
    #: ``json_summary(ds)`` the default methods call (a family may override the methods instead)
    package: str = ""
    formats: Mapping[str, Callable[..., Any]] = {}
    fit_defaults: Mapping[str, Any] = {}
    problem_options: frozenset[str] = frozenset()
    recorders: tuple[str, ...] = ()

    def parse(self, doc: Mapping[str, Any], where: str, text: str) -> Any:
        return importlib.import_module(self.package).parse(doc, where=where, text=text)

    def simulate(self, scene, solver: str | None = None, **options) -> Any:
        return importlib.import_module(self.package).simulate(scene, solver, **options)

    def json_summary(self, ds) -> dict[str, Any]:
        return importlib.import_module(self.package).json_summary(ds)

    def describe(self, ds) -> list[str]:
        """The scalar items of :meth:`json_summary` but ``status``, one per line."""
        return [f"  {k}: {v}" for k, v in self.json_summary(ds).items()
                if k != "status" and not isinstance(v, (list, dict))]

    def read(self, path, fmt: str | None = None, **options) -> Any:
        """The reader of format ``fmt`` (default :meth:`detect`'s) applied to ``path``; no options."""
        from .errors import DataError

        if options:
            raise DataError(f"{self.name} recordings take no reading option(s) {sorted(options)}", str(path))
        fmt = fmt or self.detect(path)
        if fmt not in self.formats:
            raise DataError(f"unknown {self.name} recording format {fmt!r}; known: {sorted(self.formats)}", str(path))
        return self.formats[fmt](path)

    def record(self, scene, recorder: str, path, **options) -> None:
        raise SceneError(f"{self.name} scenes have no synthetic recorder", getattr(scene, "where", None))

    def title(self, attrs: Mapping[str, Any]) -> str:
        return f"{self.name.replace('_', ' ').capitalize()} model"

    def derived(self, draws: Mapping[str, Any], attrs: Mapping[str, Any]) -> tuple[list[Derived], str]:
        return [], ""

    def figures(self, result) -> dict[str, bytes]:
        return {}

    def plain(self, draws: Mapping[str, Any], attrs: Mapping[str, Any], observed=None) -> list[str]:
        from .plainwords import coefficient_sentences

        return coefficient_sentences(draws)  # friction coefficients, the parameters every family shares

    def splits_units(self, scene) -> bool:
        return False

    def units_of(self, path, *, notch_deg: float | None = None) -> list[tuple[str, Any]] | None:
        return None

    def agreement(self, problem, lsq, refit, *, seed: int = 0) -> Any:
        return None

    def refuse_unknown_options(self, options: Mapping[str, Any], where: str | None = None) -> None:
        """Refuse problem options this family does not take (a :class:`~escfit.core.errors.FitError`)."""
        from .errors import FitError

        unknown = sorted(set(options) - set(self.problem_options))
        if unknown:
            raise FitError(f"{self.name} fits take no option(s) {unknown}; they take {sorted(self.problem_options)}",
                           where)


def register_family(family: "Family | str", name: str | None = None, *, replace: bool = False) -> None:
    """Add a model family to the registry.

    Parameters
    ----------
    family
        The family object, or the ``"<module>:<attribute>"`` path of one (imported on first use).
    name
        Its ``model =`` name (default: the object's :attr:`~Family.name`; required with a path).
    replace
        Replace a family already registered under that name (refused otherwise).

    Raises
    ------
    SceneError
        No name, or a name already taken without ``replace``.
    """
    name = name or getattr(family, "name", None)
    if not isinstance(name, str) or not name:
        raise SceneError(f"a model family needs a name, got {name!r}")
    if name in _REGISTRY and not replace:
        raise SceneError(f"model family {name!r} is already registered; pass replace=True to replace it")
    _REGISTRY[name] = family


def unregister_family(name: str) -> None:
    """Remove a family added with :func:`register_family` (a built-in one comes back as shipped,
    one an installed package declares as declared)."""
    if name in BUILTIN_FAMILIES:
        _REGISTRY[name] = BUILTIN_FAMILIES[name]
    elif name in _FROM_ENTRY_POINTS:
        _REGISTRY[name] = _FROM_ENTRY_POINTS[name]
    else:
        _REGISTRY.pop(name, None)


def _entry_points() -> None:
    """Add the families installed packages declare (:data:`ENTRY_POINT_GROUP`), once per process,
    by path (imported on first use); a name already registered keeps its entry."""
    global _SCANNED
    if _SCANNED:
        return
    _SCANNED = True
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name not in _REGISTRY:
            _REGISTRY[ep.name] = _FROM_ENTRY_POINTS[ep.name] = f"{ep.module}:{ep.attr}"  # extras, if any, dropped


def family_names() -> list[str]:
    """The registered families' names, those installed packages declare included, sorted."""
    _entry_points()
    return sorted(_REGISTRY)


def get_family(name: str) -> Family:
    """The registry entry of model family ``name``.

    Raises
    ------
    SceneError
        An unknown family name (the known ones listed).
    """
    entry = _REGISTRY.get(name) if isinstance(name, str) else None
    if entry is None and isinstance(name, str):
        _entry_points()
        entry = _REGISTRY.get(name)
    if entry is None:
        raise SceneError(f"unknown model {name!r}; known models: {family_names()}")
    if isinstance(entry, str):
        module, _, attr = entry.partition(":")
        try:
            entry = getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError) as exc:
            if name not in _FROM_ENTRY_POINTS:
                raise
            raise SceneError(f"model {name!r}: the entry point {entry!r} an installed package declares in "
                             f"{ENTRY_POINT_GROUP!r} cannot be loaded ({type(exc).__name__}: {exc})") from None
        _REGISTRY[name] = entry
    return entry


def check_options(family: Family, given: Mapping[str, Any], flags: Mapping[str, str], where: str | None) -> dict:
    """The options of ``given`` that ``family`` takes; one it does not take is refused.

    Parameters
    ----------
    family
        The scene's family.
    given
        Problem option -> value; ``None`` values (and mappings whose values are all ``None``)
        count as not given and are dropped.
    flags
        Problem option -> how the user gave it (``"--material"``), for the message.
    where
        The scene file, for the message.

    Raises
    ------
    SceneError
        Naming the option(s), the families that take them and the scene's family.
    """
    present = {k: v for k, v in given.items()
               if v is not None and not (isinstance(v, Mapping) and all(x is None for x in v.values()))}
    refused = sorted(k for k in present if k not in family.problem_options)
    if refused:
        takers = [n for n in family_names() if any(k in get_family(n).problem_options for k in refused)]
        shown = ", ".join(flags.get(f"{k}.{sub}", sub) if isinstance(present[k], Mapping) else flags.get(k, k)
                          for k in refused
                          for sub in (sorted(s for s, x in present[k].items() if x is not None)
                                      if isinstance(present[k], Mapping) else [k]))
        n = shown.count(",") + 1
        raise SceneError(f"{shown} appl{'ies' if n == 1 else 'y'} to {' and '.join(takers) or 'no'} "
                         f"scenes; this scene's model is {family.name!r}", where)
    return present
