"""Tools: the registry and guarded executor through which every agent action runs (Action + Integration layers)."""
