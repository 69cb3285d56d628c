"""Physical effects a balance scene can name, one module each."""

from .banking import Banking
from .coulomb import Coulomb
from .drag import Drag
from .escapement import Escapement, Window
from .hairspring import Hairspring
from .stiffening import Stiffening
from .viscous import Viscous
from .viscous_drift import ViscousDrift

# Order matters only for reading and filling: the escapement's eps ties need nothing earlier, and
# the stiffening's cubic term reads the reference omega0 a hairspring sets.
EFFECTS = {cls.key: cls for cls in (Viscous, ViscousDrift, Coulomb, Escapement, Hairspring, Banking, Stiffening,
                                     Drag)}

__all__ = ["EFFECTS", "Banking", "Coulomb", "Drag", "Escapement", "Hairspring", "Stiffening", "Viscous", "ViscousDrift",
           "Window"]
