"""``skinframes serve ecat``: argument checks and error lines (no root needed; the live runs are
in tests/emulator/test_live_soem.py)."""

from __future__ import annotations

import errno
import socket

import pytest

from skinframes_cli import main


class FakeSocket:
    """Stands in for AF_PACKET: ``bind`` fails like the kernel does for a missing interface."""

    def __init__(self, *args: object) -> None:
        pass

    def bind(self, addr: object) -> None:
        raise OSError(errno.ENODEV, "No such device")

    def close(self) -> None:
        pass


def denied(*args: object) -> None:
    raise PermissionError(errno.EPERM, "Operation not permitted")


@pytest.mark.parametrize(
    ("fake", "message"),
    [
        (FakeSocket, "no network interface 'ecs9'"),
        (denied, "opening a raw socket on 'ecs9' needs root or CAP_NET_RAW"),
    ],
)
def test_link_problems_are_one_error_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], fake: object, message: str
) -> None:
    monkeypatch.setattr(socket, "socket", fake)
    code = main(["serve", "ecat", "--iface", "ecs9", "--nodes", "3", "--bytes", "192"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(f"skinframes: error: {message}")
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--nodes", "0", "--bytes", "16"], "served EtherCAT chain: 0 slaves (1..1024)"),
        (["--nodes", "1025", "--bytes", "16"], "served EtherCAT chain: 1025 slaves (1..1024)"),
        (["--nodes", "2", "--bytes", "1487"], "EtherCAT: 1487 bytes per slave (1..1486)"),
        (["--nodes", "2", "--bytes", "16", "--samples", "0"], "taxel feed: 0 samples"),
        (["--nodes", "2", "--bytes", "16", "--period-ms", "0"], "taxel feed: a period of 0.0 s"),
    ],
)
def test_bad_arguments(capsys: pytest.CaptureFixture[str], args: list[str], message: str) -> None:
    """The limits are emulator.model.limits.check_served_ecat's; the check runs before any socket."""
    assert main(["serve", "ecat", "--iface", "lo", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"skinframes: error: {message}")
    assert err.count("\n") == 1
