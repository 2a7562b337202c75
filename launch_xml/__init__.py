"""zenroid's ``launch_xml``: its launch description source (the launcher reads every format itself)."""
