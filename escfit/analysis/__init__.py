"""Record analysis in stages: time base, quantity, channel, segments, checks; each stage a module with a typed result.

Stages so far: :mod:`escfit.analysis.timebase`.  Import a stage from its module; this package
imports nothing itself.
"""
