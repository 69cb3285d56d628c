"""Scene files: TOML documents naming a model and only the effects it should simulate.

The top-level key ``model`` selects the model family; each family parses the rest of the
document into its own frozen scene object.  A scene keeps its source text so results can
record exactly what produced them.
"""

from __future__ import annotations

import importlib
import tomllib
from pathlib import Path
from typing import Any, Mapping, Protocol

from .errors import SceneError
from .params import ParamSet

__all__ = ["Scene", "load_scene", "MODELS", "check_keys"]

# model name -> module that provides ``parse(doc, where, text) -> Scene`` and
# ``simulate(scene, solver=..., **options) -> xarray.Dataset``.
MODELS: dict[str, str] = {
    "balance": "escfit.balance",
    "geneva": "escfit.geneva",
    "verge": "escfit.verge",
    "friction_rig": "escfit.friction",
}


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
        raise SceneError(f"unknown key(s) {unknown}; allowed: {sorted(allowed)}", where)
    missing = sorted(required - set(table))
    if missing:
        raise SceneError(f"missing required key(s) {missing}", where)


def model_module(name: str):
    """Import the module implementing model ``name``."""
    return importlib.import_module(MODELS[name])


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
        path = Path(source)
        if not path.is_file():
            raise SceneError("scene file not found", where)
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
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"not valid TOML: {exc}", where) from None
    model = doc.get("model")
    if model is None:
        raise SceneError(f"missing key 'model' (one of {sorted(MODELS)})", where)
    if not isinstance(model, str) or model not in MODELS:
        raise SceneError(f"unknown model {model!r}; known models: {sorted(MODELS)}", f"{where} [model]")
    return model_module(model).parse(doc, where=where, text=text)
