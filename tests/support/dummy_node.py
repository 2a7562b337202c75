"""A stand-in node for the launcher's own tests and demos: it speaks the shared node CLI, declares the
graph liveliness token a real node declares, prints its parameters, and exits when told to.

``python -m tests.support.dummy_node --name N [--ns NS] [--params-file F] [--exit-after S] [--exit-code C]
[--ignore-sigint] [--start-delay S] [--child] [--detached-child] [--serve-for S] [--wedge]``
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import threading
import time

import yaml


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="dummy_node")
    parser.add_argument("--name", required=True)
    parser.add_argument("--ns", "--namespace", dest="ns", default="")
    parser.add_argument("--params-file", action="append", default=[])
    parser.add_argument("--remap", action="append", default=[])
    parser.add_argument("--exit-after", type=float, default=None, help="exit after this many seconds")
    parser.add_argument("--exit-code", type=int, default=0)
    parser.add_argument("--ignore-sigint", action="store_true", help="a stubborn node: needs SIGTERM/SIGKILL")
    parser.add_argument("--start-delay", type=float, default=0.0, help="seconds before the liveliness token")
    parser.add_argument("--child", action="store_true", help="also start a sleeping child process")
    parser.add_argument("--detached-child", action="store_true",
                        help="also start a sleeping process in its own session (escapes the node's group)")
    parser.add_argument("--serve-for", type=float, default=None,
                        help="answer <name>/get_parameters (the launcher's health probe) for S seconds, then hang")
    parser.add_argument("--wedge", action="store_true",
                        help="with --serve-for: then wedge as a node whose Zenoh session broke does: the probe's "
                             "callback blocks (its query never ends) and the main thread blocks too")
    args = parser.parse_args(argv)

    stop = threading.Event()
    if args.ignore_sigint:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    else:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
    for path in args.params_file:
        with open(path, encoding="utf-8") as f:
            print(f"params {yaml.safe_dump(yaml.safe_load(f), default_flow_style=True).strip()}", flush=True)
    child = None
    if args.child:
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
        print(f"child pid {child.pid}", flush=True)
    if args.detached_child:
        detached = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"], start_new_session=True)
        print(f"detached child pid {detached.pid}", flush=True)
    time.sleep(args.start_delay)

    from nodes.core import graph
    from nodes.core.session import open_peer

    full_name = f"{args.ns.strip('/')}/{args.name}" if args.ns.strip("/") else args.name
    session = open_peer()
    # the graph names nodes by their fully qualified name, "/ns/name", as nodes.core.Node does
    token = session.liveliness().declare_token(graph.node_key(str(session.zid()), "/" + full_name))
    served_until = time.monotonic() + (args.serve_for or 0.0)

    wedged = threading.Event()

    def on_query(query) -> None:  # noqa: ANN001 - a zenoh query
        if time.monotonic() < served_until:
            query.reply(query.key_expr, b"\x80")  # an empty msgpack map
        elif args.wedge:
            wedged.set()
            threading.Event().wait()   # holds the query: only the router's timeout ends it
        # afterwards: no reply, as from a node whose loop is stuck

    queryable = session.declare_queryable(f"{full_name}/get_parameters", on_query) if args.serve_for else None
    print(f"ready {full_name}", flush=True)
    if args.wedge:
        wedged.wait()
        print(f"wedged {full_name}", flush=True)
        stuck = threading.Lock()
        stuck.acquire()
        stuck.acquire()   # a signal handler runs, and the main thread waits on: only SIGKILL ends it
    try:
        stop.wait(args.exit_after)
    finally:
        if queryable is not None:
            queryable.undeclare()
        token.undeclare()
        session.close()
    print(f"bye {full_name}", flush=True)
    return args.exit_code


if __name__ == "__main__":
    sys.exit(main())
