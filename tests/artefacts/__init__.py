"""Synthetic free-decay records with known truth, each carrying one real-world artefact.

The truth (omega0, C, R, D, the free window, the angle column, the verdict a careful analysis
should reach) comes from the generator in :mod:`.make`, never from escfit's own record analysis:
the free decays are solved by escfit's forward simulator (a pendulum scene released at rest),
everything around them (a hand, a hold, a push, a clock, a second channel) is written here.
"""

from .make import CLASSES, Artefact, Truth, make

__all__ = ["CLASSES", "Artefact", "Truth", "make"]
