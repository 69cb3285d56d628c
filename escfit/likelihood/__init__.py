"""The language every family's fit problem speaks: priors, free-parameter vectors, the Problem protocol."""
