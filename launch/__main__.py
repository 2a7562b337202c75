"""``python -m launch FILE.yaml [name:=value ...]``."""

import sys

from launch import interrupts

interrupts.install()  # first: Ctrl-C must work from the first instant (see launch.interrupts)

from launch.cli import main  # noqa: E402 - after the signal handlers on purpose

sys.exit(main())
