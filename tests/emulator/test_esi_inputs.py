"""Input values from a file for ESI slaves (``serve ecat --esi-inputs``).

Expected values: the file's rows (written here), ETG.1000.6 5.6.7's packing of PDO entries (bit
by bit from bit 0, little-endian; worked out by hand below) and the LAN9252 ESI's one input
entry (TxPdo 0x1A00 on Sm 3: 0x6000:1, BitLen 8).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from emulator.slave.esi_inputs import pack_entries, read_esi_inputs
from emulator.slave.esi_slave import EsiApplication, entry_values, esi_device, load_esi_slave
from skinframes.errors import DecodeError
from skinframes_cli import main

LAN9252 = "soes_linux_lan9252demo.xml"
PREOP = 0x02
INPUT_SM = 3  # the ESI's TxPdo Sm


def test_entries_are_packed_bit_by_bit() -> None:
    # 1 bit, a 3-bit gap, 12 bits, 16 bits: bit 0 = 1, bits 4-15 = 0xABC, bits 16-31 = 0x1234
    layout = [(0x6000, 1, 1), (0, 0, 3), (0x6000, 2, 12), (0x6001, 0, 16)]
    data = pack_entries(layout, [1, 7, 0xABC, 0x1234])
    assert data == bytes.fromhex("c1ab3412")
    assert entry_values(layout, data) == [
        (0x6000, 1, b"\x01"),
        (0x6000, 2, bytes.fromhex("bc0a")),
        (0x6001, 0, bytes.fromhex("3412")),
    ]


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "inputs.csv"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_file_is_read_against_the_txpdos(shared_esi: Path, tmp_path: Path) -> None:
    device = load_esi_slave(str(shared_esi / LAN9252)).device
    path = write(tmp_path, "# Button1 of the demo board\n\n#x6000:1\n1\n0xff\n-1\n")
    inputs = read_esi_inputs(path, device)
    assert (inputs.entries, inputs.bits) == (((0x6000, 1),), (8,))
    assert inputs.rows == ((1,), (0xFF,), (0xFF,))  # -1 as 8 bits
    assert [inputs.value(0x6000, 1, c) for c in range(5)] == [1, 0xFF, 0xFF, 1, 0xFF]
    assert inputs.value(0x6000, 2, 0) is None  # not in the file: the counter's


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("0x6000:2\n1\n", "line 1: 0x6000:2 is no entry of a TxPDO of evb9252_dig"),
        ("0x6000\n1\n", "line 1: '0x6000' is not INDEX:SUBINDEX"),
        ("0x6000:1,0x6000:1\n1,2\n", "line 1: an entry is named twice"),
        ("0x6000:1\n1\n256\n", "line 3: 256 does not fit 8 bits"),
        ("0x6000:1\n-129\n", "line 2: -129 does not fit 8 bits"),
        ("0x6000:1\n\n1,2\n", "line 3: 2 values, the header names 1"),
        ("0x6000:1\nx\n", "line 2: 'x' is not a number"),
        ("# only a comment\n", "no header and rows"),
        ("0x6000:1\n", "no header and rows"),
    ],
)
def test_a_bad_file_names_its_line(
    shared_esi: Path, tmp_path: Path, text: str, message: str
) -> None:
    device = load_esi_slave(str(shared_esi / LAN9252)).device
    with pytest.raises(DecodeError, match=message):
        read_esi_inputs(write(tmp_path, text), device)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        # 0xe9 (Latin-1 "é") followed by a newline is no UTF-8 sequence; line 2 as the user counts
        (b"0x6000:1\n\xe9\n", "line 2: byte 0xe9 is not UTF-8 text"),
        (b"0x6000:1\n1\n\x00\xff\xfe\n", "line 3: byte 0xff is not UTF-8 text"),
        # a cell over the csv module's 131072-character field limit
        (b"0x6000:1\n1," + b"7" * 200_000 + b"\n", "line 2: not CSV: field larger than"),
        # one byte over the 4 MiB limit, refused before it is read whole
        ((b"0x6000:1\n" + b"1\n" * (2 << 20))[: (4 << 20) + 1], "larger than 4 MiB"),
    ],
)
def test_a_hostile_file_is_one_decode_error(
    shared_esi: Path, tmp_path: Path, data: bytes, message: str
) -> None:
    device = load_esi_slave(str(shared_esi / LAN9252)).device
    path = tmp_path / "inputs.csv"
    path.write_bytes(data)
    with pytest.raises(DecodeError, match=f"^{path}: {message}"):
        read_esi_inputs(path, device)


def test_simulate_refuses_a_file_that_is_not_text_in_one_line(
    capsys: pytest.CaptureFixture[str], shared_esi: Path, tmp_path: Path
) -> None:
    latin1 = tmp_path / "in4.csv"
    latin1.write_bytes(b"0x6000:1\n\xe9\n")  # the user's report: a traceback, exit 1
    argv = ["simulate", "ecat", "--nodes", "0", "--bytes", "1", "--esi", str(shared_esi / LAN9252)]
    for inputs, message in (
        (latin1, f"{latin1}: line 2: byte 0xe9 is not UTF-8 text"),
        (tmp_path, f"--esi-inputs {tmp_path}: Is a directory"),
    ):
        code = main([*argv, "--esi-inputs", str(inputs)])
        err = capsys.readouterr().err
        assert (code, err) == (2, f"skinframes: error: {message}\n")


def test_the_slave_publishes_the_rows_in_turn(shared_esi: Path, tmp_path: Path) -> None:
    slave = load_esi_slave(str(shared_esi / LAN9252))
    path = write(tmp_path, "0x6000:1\n0x11\n0x22\n0x33\n")
    dev = esi_device(dataclasses.replace(slave, inputs=read_esi_inputs(path, slave.device)))
    app = dev.app
    assert isinstance(app, EsiApplication) and app.objects is not None
    seen = []
    for c in range(5):
        app.counter = c  # publication c
        sdo = app.objects.read(0x6000, 1, PREOP)  # the input object over SDO
        seen.append((app.image(INPUT_SM), sdo))
    rows = [b"\x11", b"\x22", b"\x33", b"\x11", b"\x22"]
    assert seen == [(r, r) for r in rows]
    # without a file: the counter (the README's default)
    plain = esi_device(slave).app
    assert isinstance(plain, EsiApplication)
    plain.counter = 0x1FE
    assert plain.image(INPUT_SM) == b"\xfe"


def test_serve_refuses_bad_inputs_in_one_line(
    capsys: pytest.CaptureFixture[str], shared_esi: Path, tmp_path: Path
) -> None:
    esi = str(shared_esi / LAN9252)
    good = str(write(tmp_path, "0x6000:1\n1\n"))
    bad = tmp_path / "bad.csv"
    bad.write_text("0x6000:1\n300\n", encoding="utf-8")
    for argv, message in (
        (["--esi", esi, "--esi-inputs", str(bad)], f"{bad}: line 2: 300 does not fit 8 bits"),
        (["--esi", esi, "--esi-inputs", good, "--esi-inputs", good], "2 files for 1 --esi"),
        (["--esi", esi, "--esi-inputs", str(tmp_path / "none.csv")], "none.csv: No such file"),
    ):
        code = main(["serve", "ecat", "--iface", "lo", "--nodes", "0", *argv])
        err = capsys.readouterr().err
        assert code == 2 and err.startswith("skinframes: error:") and message in err, err
        assert err.count("\n") == 1
    code = main(
        ["serve", "epl", "--iface", "lo", "--nodes", "1", "--bytes", "8", "--esi-inputs", good]
    )
    assert code == 2 and "--esi-inputs applies to serve ecat only" in capsys.readouterr().err
