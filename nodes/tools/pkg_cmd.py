"""``zenroid pkg`` (``ros2 pkg``): the packages the index finds (docs/packages.md).

    zenroid pkg list                 every package, one a line
    zenroid pkg prefix PKG           its install prefix (a source package's own folder); --share: its share folder
    zenroid pkg executables [PKG]    ``PKG EXEC`` lines; --full-path: the command each runs
    zenroid pkg xml PKG [-t TAG]     its package.xml (or one tag's text)
    zenroid pkg create NAME [--build-type ament_python] [--dependencies ...] [--node-name N]
"""

from __future__ import annotations

import argparse
from pathlib import Path
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
    p = sub.add_parser("create", help="a new package's files (ament_python or ament_cmake), as ros2 pkg create")
    p.add_argument("package_name")
    p.add_argument("--build-type", default="ament_cmake", choices=["ament_python", "ament_cmake", "cmake"])
    p.add_argument("--dependencies", nargs="*", default=[])
    p.add_argument("--destination-directory", default=".")
    p.add_argument("--node-name", help="also a node script and its console_scripts entry (ament_python)")
    p.add_argument("--library-name", help="(accepted for ament_cmake)")
    p.add_argument("--description", default="TODO: Package description")
    p.add_argument("--license", default="TODO: License declaration")
    p.add_argument("--maintainer-email", default="user@todo.todo")
    p.add_argument("--maintainer-name", default="user")


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
        create(args)
    return 0


PACKAGE_XML = """<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format3.xsd" schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="3">
  <name>{name}</name>
  <version>0.0.0</version>
  <description>{description}</description>
  <maintainer email="{email}">{maintainer}</maintainer>
  <license>{license}</license>

{buildtool}{depends}
  <export>
    <build_type>{build_type}</build_type>
  </export>
</package>
"""

SETUP_PY = """from setuptools import find_packages, setup

package_name = '{name}'

setup(
    name=package_name,
    version='0.0.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='{maintainer}',
    maintainer_email='{email}',
    description='{description}',
    license='{license}',
    entry_points={{
        'console_scripts': [{entry}
        ],
    }},
)
"""

NODE_PY = """def main():
    print('Hi from {name}.')


if __name__ == '__main__':
    main()
"""


def create(args: argparse.Namespace) -> None:
    """The files ``ros2 pkg create`` writes; nothing needs building here: the folder is the package."""
    name = args.package_name
    if not name.isidentifier() or name != name.lower():
        raise UsageError(f"package name '{name}' must be lower case letters, digits and '_', starting with a letter")
    root = Path(args.destination_directory) / name
    if root.exists():
        raise Failed(f"{root} already exists")
    python = args.build_type == "ament_python"
    depends = "".join(f"  <depend>{d}</depend>\n" for d in args.dependencies)
    buildtool = "" if python else "  <buildtool_depend>ament_cmake</buildtool_depend>\n"
    text = dict(name=name, description=args.description, email=args.maintainer_email,
                maintainer=args.maintainer_name, license=args.license)
    files = {"package.xml": PACKAGE_XML.format(**text, buildtool=buildtool, depends=depends,
                                               build_type=args.build_type)}
    if python:
        entry = f"\n            '{args.node_name} = {name}.{args.node_name}:main'," if args.node_name else ""
        files.update({"setup.py": SETUP_PY.format(**text, entry=entry),
                      "setup.cfg": f"[develop]\nscript_dir=$base/lib/{name}\n[install]\n"
                                   f"install_scripts=$base/lib/{name}\n",
                      f"resource/{name}": "", f"{name}/__init__.py": ""})
        if args.node_name:
            files[f"{name}/{args.node_name}.py"] = NODE_PY.format(name=name)
    else:
        files["CMakeLists.txt"] = (f"cmake_minimum_required(VERSION 3.8)\nproject({name})\n\n"
                                   "find_package(ament_cmake REQUIRED)\n"
                                   + "".join(f"find_package({d} REQUIRED)\n" for d in args.dependencies)
                                   + "\nament_package()\n")
        (root / "include" / name).mkdir(parents=True)
        (root / "src").mkdir()
    for relative, content in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(content, encoding="utf-8")
        print(f"creating ./{name}/{relative}")
    print(f"{name}: a package now, no build needed (zenroid finds it in the workspace's src/ and on "
          "ROS_PACKAGE_PATH)")
