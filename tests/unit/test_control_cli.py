"""``zenroid control`` argument handling that needs no running manager (exit 2 on bad input)."""

from __future__ import annotations

import pytest

from nodes.tools import cli


@pytest.mark.parametrize("argv, message", [
    (["control", "set_controller_state", "jtc", "dancing"], "inactive' or 'active"),
    (["control", "switch_controllers"], "nothing to switch"),
])
def test_bad_input_exits_2_with_one_line(argv, message, capsys):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_bad_choice_is_an_argparse_error(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["control", "load_controller", "jtc", "--set-state", "sleeping"])
    assert info.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_unreachable_manager_is_exit_1(capsys):
    import socket

    with socket.socket() as s:  # a port nobody listens on: no router, no manager
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code = cli.main(["control", "list_controllers", "--zenoh-port", str(port), "--timeout", "0.5"])
    assert code == 1
    assert "no Zenoh router answers" in capsys.readouterr().err
