"""A fit problem by the scene's family: ``model =`` name -> :class:`~escfit.core.family.Family` -> problem.

The registry itself is :mod:`escfit.core.family`; :func:`family` is its
:func:`~escfit.core.family.get_family`, named as the inference layer has always named it.
"""

from __future__ import annotations

from ..core.family import get_family as family
from ..core.scene import load_scene
from ..likelihood.problem import Problem

__all__ = ["family", "make_problem"]


def make_problem(scene, data, **options) -> Problem:
    """The fit problem of a scene (object or path) and a recording (object or path).

    ``options`` are the family's (see each family's ``problem``); unknown ones are refused.
    """
    sc = load_scene(scene) if not hasattr(scene, "model") else scene
    return family(sc.model).problem(sc, data, **options)
