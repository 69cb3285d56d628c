"""Physical effects a balance scene can name, one module each."""

from .banking import Banking
from .coulomb import Coulomb
from .escapement import Escapement, Window
from .hairspring import Hairspring
from .viscous import Viscous
from .viscous_drift import ViscousDrift

# Order matters only for reading and filling: the escapement's eps ties need nothing earlier.
EFFECTS = {cls.key: cls for cls in (Viscous, ViscousDrift, Coulomb, Escapement, Hairspring, Banking)}

__all__ = ["EFFECTS", "Banking", "Coulomb", "Escapement", "Hairspring", "Viscous", "ViscousDrift", "Window"]
