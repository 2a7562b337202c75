"""``python -m msgs.stubs DIR``: write the interface packages' type stubs into DIR (see msgs.stubs)."""

import sys
from pathlib import Path

from msgs.stubs import write_stubs


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: python -m msgs.stubs DIR   (then point your IDE's stub path at DIR)", file=sys.stderr)
        return 2
    written = write_stubs(Path(argv[0]))
    print(f"{len(written)} stub modules in {argv[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
