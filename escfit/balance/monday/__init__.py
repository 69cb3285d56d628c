"""Monday's analytic one-cycle map of the balance wheel and the charts computed from it."""
