"""zenroid's ``launch_yaml``: its launch description source (the launcher reads every format itself)."""
