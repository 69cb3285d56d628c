"""Scene files: TOML documents naming a model and only the effects it should simulate.

The top-level key ``model`` selects the model family (:mod:`escfit.core.family`); each family parses the rest of the
document into its own frozen scene object.  A scene keeps its source text so results can
record exactly what produced them.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any, Mapping, Protocol

from .errors import SceneError
from .suggest import did_you_mean
from .params import ParamSet

__all__ = ["Scene", "load_scene", "parse_toml", "check_keys", "MAX_DEPTH", "MAX_SCENE_BYTES"]

# Deepest nesting of tables and arrays a scene or recipe may have: real ones use 3 or 4
# (effects.escapement[1].X.prior); tomllib recurses once per level and fails with a bare
# RecursionError near 1000
MAX_DEPTH = 16
# Largest scene or recipe text, bytes: real ones are a few kB (a 1000-piece hairspring is 20 kB);
# a million-piece spring (20 MB) would run for hours before any error could be reported
MAX_SCENE_BYTES = 1_000_000

class Scene(Protocol):
    """What every model's scene object offers."""

    model: str
    params: ParamSet
    text: str
    where: str


def check_keys(table: Mapping[str, Any], allowed: set[str], where: str, required: set[str] = frozenset()) -> None:
    """Refuse unknown or missing keys of a TOML table, naming the file and table."""
    if not isinstance(table, Mapping):
        raise SceneError(f"expected a table, got {table!r}", where)
    unknown = sorted(set(table) - allowed)
    if unknown:
        hints = "".join(did_you_mean(k, allowed) for k in unknown)
        raise SceneError(f"unknown key(s) {unknown}{hints}; allowed: {sorted(allowed)}", where)
    missing = sorted(required - set(table))
    if missing:
        raise SceneError(f"missing required key(s) {missing}", where)


def parse_toml(text: str, where: str) -> dict:
    """Parse TOML ``text``; a syntax error, nesting deeper than :data:`MAX_DEPTH` or a text
    longer than :data:`MAX_SCENE_BYTES` is a :class:`SceneError` naming ``where`` (the line,
    for syntax errors)."""
    if len(text) > MAX_SCENE_BYTES:
        raise SceneError(f"{len(text) / 1e6:.3g} MB of text; a scene or recipe is a few kB, at most "
                         f"{MAX_SCENE_BYTES / 1e6:g} MB", where)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"not valid TOML: {exc}", where) from None
    except RecursionError:
        raise SceneError(f"tables or arrays nested too deeply (more than {MAX_DEPTH} levels)", where) from None
    path = _deep_key(doc, MAX_DEPTH)
    if path is not None:
        raise SceneError(f"tables or arrays nested more than {MAX_DEPTH} levels deep", f"{where} [{path}]")
    return doc


def _deep_key(value: Any, budget: int, path: str = "") -> str | None:
    """The key path at which ``value`` nests deeper than ``budget`` levels, or ``None``."""
    if isinstance(value, (dict, list)) and budget <= 0:
        return path or "(top)"
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        found = _deep_key(item, budget - 1, f"{path}.{key}" if path and isinstance(key, str) else
                          (f"{path}[{key}]" if not isinstance(key, str) else key))
        if found is not None:
            return found
    return None


def load_scene(source: str | Path, *, text: str | None = None) -> "Scene":
    """Read and validate a scene.

    Parameters
    ----------
    source
        Path to a ``.toml`` scene file.  When ``text`` is given, ``source`` is only the
        name used in messages.
    text
        TOML text to parse instead of reading ``source``.

    Returns
    -------
    Scene
        The model family's scene object (e.g. :class:`escfit.balance.BalanceScene`).

    Raises
    ------
    SceneError
        Unreadable file, TOML syntax error (with line), unknown model, or any problem
        the model's parser finds (naming the key and value).
    """
    where = str(source)
    if text is None:
        from .inputs import check_input_file

        path = Path(source)
        check_input_file(path, "scene", SceneError)
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise SceneError(f"cannot read scene file ({exc.strerror or exc})", where) from None
        from .errors import DataError
        from .textfile import decode_text

        try:
            text = decode_text(raw, where, what="a TOML scene")
        except DataError as exc:
            raise SceneError(exc.message, exc.where) from None
    elif text.startswith("\ufeff"):
        text = text[1:]
    doc = parse_toml(text, where)
    from .family import family_names, get_family

    model = doc.get("model")
    if model is None:
        raise SceneError(f"missing key 'model' (one of {family_names()})", where)
    if not isinstance(model, str) or model not in family_names():
        raise SceneError(f"unknown model {model!r}{did_you_mean(model, family_names())}; known models: "
                         f"{family_names()}", f"{where} [model]")
    return get_family(model).parse(doc, where=where, text=text)
