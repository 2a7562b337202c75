"""``zenroid interface`` (``ros2 interface``): the message, service and action definitions zenroid knows (its
own and those of interface packages the package index finds).

    zenroid interface list [-m|-s|-a]      every type, "pkg/kind/Name"
    zenroid interface packages             packages with interfaces
    zenroid interface package PKG          one package's types
    zenroid interface show TYPE            the definition file's text
    zenroid interface proto TYPE           a YAML prototype of the message (request/goal for srv/action)
"""

from __future__ import annotations

import argparse

import yaml

import msgs
from msgs.registry import definition_file
from nodes.tools.errors import Failed

KINDS = {"msgs": "msg", "services": "srv", "actions": "action"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list", help="every interface type")
    p.add_argument("-m", "--only-msgs", dest="only", action="append_const", const="msg")
    p.add_argument("-s", "--only-srvs", dest="only", action="append_const", const="srv")
    p.add_argument("-a", "--only-actions", dest="only", action="append_const", const="action")
    sub.add_parser("packages", help="packages that define interfaces")
    p = sub.add_parser("package", help="the types of one package")
    p.add_argument("package")
    p = sub.add_parser("show", help="a type's definition")
    p.add_argument("type")
    p.add_argument("--all-comments", action="store_true", help="(accepted: the file is shown as written)")
    p.add_argument("--no-comments", action="store_true", help="leave comment lines and trailing comments out")
    p = sub.add_parser("proto", help="a YAML prototype of a message")
    p.add_argument("type")
    p.add_argument("--no-quotes", action="store_true", help="(accepted)")


def _types(only: list[str] | None = None) -> list[str]:
    return [t for t in msgs.list_types() if not only or t.split("/")[1] in only]


def run(args: argparse.Namespace) -> int:
    if args.cmd == "list":
        found = _types(args.only)
        for title, kind in (("Messages", "msg"), ("Services", "srv"), ("Actions", "action")):
            rows = [t for t in found if t.split("/")[1] == kind]
            if rows:
                print(f"{title}:")
                for row in rows:
                    print(f"    {row}")
    elif args.cmd == "packages":
        for name in msgs.package_names():
            print(name)
    elif args.cmd == "package":
        rows = [t for t in msgs.list_types() if t.split("/")[0] == args.package]
        if not rows:
            raise Failed(f"package '{args.package}' defines no interfaces (zenroid interface packages lists those "
                         "that do)")
        print("\n".join(rows))
    elif args.cmd == "show":
        try:
            path = definition_file(args.type)
        except KeyError as exc:
            raise Failed(str(exc).strip("'\"")) from None
        if path is None:
            raise Failed(f"unknown interface type '{args.type}' (zenroid interface list shows the known ones)")
        text = path.read_text(encoding="utf-8")
        if args.no_comments:
            lines = [line.split("#", 1)[0].rstrip() for line in text.splitlines()]
            text = "\n".join(line for line in lines if line) + "\n"
        print(text, end="" if text.endswith("\n") else "\n")
    elif args.cmd == "proto":
        name = args.type
        try:
            kind = name.split("/")[1] if name.count("/") == 2 else None
            if kind == "srv":
                name = f"{name}_Request"
            elif kind == "action":
                name = f"{name}_Goal"
            message = msgs.get_type(name)()
        except (KeyError, TypeError) as exc:
            raise Failed(f"unknown message type '{args.type}': {exc}") from None
        print(yaml.safe_dump(msgs.to_dict(message), default_flow_style=False, sort_keys=False), end="")
    return 0
