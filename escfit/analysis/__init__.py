"""Record analysis, from a file on disk to the stretch of it a model may be fitted to.

The stages, each a module with a typed result the report shows:

- ``recordings``: the format registry (a sniff per format, a reader per format) and the
  reduction of a sampled swing to turning points;
- ``timebase``, ``runs``: what loggers do to the clock, repaired or refused;
- ``quantity``, ``roles``, ``channel``, ``pendulum_unit``: what a column holds, and which one swings;
- ``segments``, ``glitches``: where the free decay starts and ends;
- ``agreement``: after a fit, whether the model's turning points keep to the record's.

Nothing here knows a balance wheel, a pendulum's scene or a likelihood; the model families
import from here, never the other way.
"""
