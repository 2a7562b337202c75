"""``zenroid pkg`` (``ros2 pkg``): the packages the index finds (docs/packages.md).

    zenroid pkg list                 every package, one a line
    zenroid pkg prefix PKG           its install prefix (a source package's own folder); --share: its share folder
    zenroid pkg executables [PKG]    ``PKG EXEC`` lines; --full-path: the command each runs
    zenroid pkg xml PKG [-t TAG]     its package.xml (or one tag's text)
"""

from __future__ import annotations

import argparse
from xml.etree import ElementTree

from nodes.packages import PackageNotFoundError, executables, find_package, list_packages, stack
from nodes.tools.errors import Failed, UsageError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    sub.add_parser("list", help="every package the index finds")
    p = sub.add_parser("prefix", help="a package's prefix")
    p.add_argument("package")
    p.add_argument("--share", action="store_true", help="its share directory instead")
    p = sub.add_parser("executables", help="a package's executables (every package's without one)")
    p.add_argument("package", nargs="?")
    p.add_argument("--full-path", action="store_true", help="the command each runs")
    p = sub.add_parser("xml", help="a package's package.xml")
    p.add_argument("package")
    p.add_argument("-t", "--tag", help="only this tag's text, one a line")
    p = sub.add_parser("create", help="(not served: write package.xml and folders yourself; see docs/packages.md)")
    p.add_argument("rest", nargs=argparse.REMAINDER)


def _package(name: str):
    try:
        return find_package(name)
    except PackageNotFoundError as exc:
        raise Failed(f"{exc}\n  served by zenroid: {', '.join(stack.served())}") from None


def run(args: argparse.Namespace) -> int:
    if args.cmd == "list":
        for name in list_packages():
            print(name)
    elif args.cmd == "prefix":
        package = _package(args.package)
        print(package.share if args.share else package.prefix)
    elif args.cmd == "executables":
        names = [args.package] if args.package else list(list_packages())
        for name in names:
            if args.package:
                _package(name)
            for exe_name, exe in sorted(executables(name).items()):
                print(" ".join(exe.argv) if args.full_path else f"{name} {exe_name}")
    elif args.cmd == "xml":
        package = _package(args.package)
        path = package.share / "package.xml"
        if not path.is_file():
            raise Failed(f"package '{args.package}' has no package.xml in {package.share}")
        if not args.tag:
            print(path.read_text(encoding="utf-8"), end="")
            return 0
        try:
            root = ElementTree.parse(path).getroot()
        except ElementTree.ParseError as exc:
            raise Failed(f"{path}: {exc}") from None
        for element in root.iter(args.tag):
            print((element.text or "").strip())
    elif args.cmd == "create":
        raise UsageError("'pkg create' is not served: a folder with a package.xml is a package, no build step "
                         "(docs/packages.md shows one)")
    return 0
