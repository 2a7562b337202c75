"""``python -m nodes.tools VERB ...`` is ``zenroid VERB ...``."""

import sys

from nodes.tools.cli import main

sys.exit(main())
