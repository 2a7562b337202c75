"""``python -m nodes.packages.entry SOURCE module:function [args]``: a package's ``console_scripts`` entry run
from its unbuilt source folder, as the script colcon would have installed does after the build."""

from __future__ import annotations

import importlib
import sys


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if len(argv) < 2 or ":" not in argv[1]:
        print("usage: python -m nodes.packages.entry SOURCE_DIR module:function [args ...]", file=sys.stderr)
        return 2
    source, target, rest = argv[0], argv[1], argv[2:]
    module_name, _, attribute = target.partition(":")
    sys.path.insert(0, source)
    sys.argv = [target, *rest]
    function = importlib.import_module(module_name)
    for part in attribute.split("."):
        function = getattr(function, part)
    result = function()
    return result if isinstance(result, int) else 0


if __name__ == "__main__":
    sys.exit(main())
