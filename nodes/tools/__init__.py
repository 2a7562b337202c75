"""Command-line tools: the ``zenroid`` verbs (one module each)."""
