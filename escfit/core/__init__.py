"""What every layer stands on: errors, units, parameters, scene files, tables, atomic writes.

Nothing here knows a mechanism, a solver or a fit.
"""
