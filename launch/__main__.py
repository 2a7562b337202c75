"""``python -m launch FILE.yaml [name:=value ...]``."""

import sys

from launch.cli import main

sys.exit(main())
