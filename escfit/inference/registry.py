"""The model families by name: a scene's ``model =`` value -> its :class:`ModelFamily` entry.

Each family package (listed in :data:`escfit.core.scene.MODELS`) holds a ``family`` module
defining ``FAMILY``; it is imported only when a fit of that family is asked for.
"""

from __future__ import annotations

import importlib

from ..core.errors import SceneError
from ..core.scene import MODELS, load_scene
from ..likelihood.problem import ModelFamily, Problem

__all__ = ["family", "make_problem"]


def family(name: str) -> ModelFamily:
    """The registry entry of model family ``name``.

    Raises
    ------
    SceneError
        An unknown family name.
    """
    if name not in MODELS:
        raise SceneError(f"unknown model {name!r}; known models: {sorted(MODELS)}")
    return importlib.import_module(MODELS[name] + ".family").FAMILY


def make_problem(scene, data, **options) -> Problem:
    """The fit problem of a scene (object or path) and a recording (object or path).

    ``options`` are the family's (see each family's ``problem``); unknown ones are refused.
    """
    sc = load_scene(scene) if not hasattr(scene, "model") else scene
    return family(sc.model).problem(sc, data, **options)
