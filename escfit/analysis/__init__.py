"""Record analysis in stages: time base, quantity, channel, segments, checks; each stage a module with a typed result."""
