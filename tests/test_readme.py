"""Every ``skinframes`` command line and the Python block of the README run as shown.

Input files the README names (``capture.pcapng``, ``trace.asc``, ``trace.blf``, ``old.log``,
``skin.pcap``, the ESI file ``slave.xml``) are made first, from the demo's CAN trace and an emulated capture; then each
command runs in process in that directory. ``serve`` and ``--iface`` need a live interface and
root: their lines are parsed here; tests/emulator/test_live_soem.py and tests/test_cli_live.py run
them on veth pairs.
"""

from __future__ import annotations

import itertools
import os
import re
import shlex
from pathlib import Path

import pytest

from skinframes.canbus.log import read_can_log, write_can_log
from skinframes_cli import build_parser, main

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()


def _command_lines() -> list[str]:
    blocks = re.findall(r"```sh\n(.*?)```", README, flags=re.S)
    lines = [line.split(" #")[0].strip() for block in blocks for line in block.splitlines()]
    return [line for line in lines if line.startswith("skinframes ")]


COMMANDS = _command_lines()
# the README's "Exit status" paragraph: 0 ok, 1 check found an error, 2 bad input; every line of
# the README runs on good input, and its capture is clean, so each documents exit status 0
EXIT_STATUS = dict(re.findall(r"(\d) ([^,]+)", README.split("Exit status:", 1)[1].split("\n\n")[0]))
EXIT = {"check": 0}


# A small ESI file of our own (ETG.2000) for the README's `sii` line
SLAVE_ESI = """<?xml version="1.0"?>
<EtherCATInfo>
  <Vendor><Id>#x534B494E</Id><Name>skinframes</Name></Vendor>
  <Descriptions>
    <Devices>
      <Device Physics="YY">
        <Type ProductCode="#x100C0" RevisionNo="#x10000">SKIN-192</Type>
        <Name>SkinPatch192</Name>
        <Fmmu>Inputs</Fmmu>
        <Sm StartAddress="#x1000" DefaultSize="192" ControlByte="#x20" Enable="1">Inputs</Sm>
        <TxPdo Fixed="1" Mandatory="1" Sm="0"><Index>#x1a00</Index><Name>Taxels</Name>
          <Entry><Index>#x6000</Index><SubIndex>1</SubIndex><BitLen>96</BitLen>
            <Name>Triangle 0</Name><DataType>OCTET_STRING</DataType></Entry>
        </TxPdo>
        <Eeprom><ByteSize>2048</ByteSize><ConfigData>0500</ConfigData></Eeprom>
      </Device>
    </Devices>
  </Descriptions>
</EtherCATInfo>
"""


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("readme")
    old = Path.cwd()
    os.chdir(d)
    try:
        assert main(["demo", "--out", "out", "--no-plot"]) == 0
        frames = read_can_log("out/skin_can.asc").frames
        for name in ("trace.asc", "trace.blf", "old.log", "skin.pcap"):
            write_can_log(name, frames)
        Path("slave.xml").write_text(SLAVE_ESI)
        assert (
            main(["simulate", "epl", "--nodes", "4", "--bytes", "192", "--pcap", "capture.pcapng"])
            == 0
        )
    finally:
        os.chdir(old)
    return d


def test_the_readme_sii_line_writes_an_image_that_decodes(workdir: Path) -> None:
    from skinframes.sii import decode_sii

    assert "skinframes sii slave.xml --out slave.bin" in COMMANDS
    old = Path.cwd()
    os.chdir(workdir)
    try:
        assert main(["sii", "slave.xml", "--out", "slave.bin"]) == 0
        image = decode_sii(Path("slave.bin").read_bytes()).image
    finally:
        os.chdir(old)
    assert (image.vendor_id, image.product_code, image.revision) == (0x534B494E, 0x100C0, 0x10000)
    assert [(p.index, p.sync_manager) for p in image.tx_pdos] == [(0x1A00, 0)]


def test_the_readme_names_commands() -> None:
    assert len(COMMANDS) >= 20 and any(c.startswith("skinframes serve") for c in COMMANDS)
    assert EXIT_STATUS["0"] == "ok" and EXIT_STATUS["1"].startswith("`check` found an error")


def test_the_wire_table_line_covers_every_epl_node(
    workdir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    line = "skinframes tables --preset wire --nodes 1:239:1 --bytes 192 --json"
    assert line in COMMANDS
    assert main(shlex.split(line)[1:]) == 0
    doc = json.loads(capsys.readouterr().out)
    for table in ("epl", "ecat", "ecat_closed_ring", "ecat_redundant"):
        assert list(doc[table]) == [str(n) for n in range(1, 240)], table
    # growing with the nodes, as every cycle-time model must
    epl = [doc["epl"][str(n)]["192"] for n in range(1, 240)]
    assert all(a < b for a, b in itertools.pairwise(epl))


def test_capture_mode_raises_only_below_an_ethernet_header() -> None:
    """README: capture mode never loses a byte; it raises only for fewer than 14 bytes."""
    from skinframes import decode_frame
    from skinframes.errors import DecodeError, TruncatedError

    with pytest.raises(TruncatedError):
        decode_frame(bytes(13))
    for n in (14, 15, 59, 60):
        assert decode_frame(bytes(n)).to_bytes() == bytes(n)
    group_src = bytes(6) + b"\x01" + bytes(5) + b"\x88\xa4" + bytes(46)
    assert [f.code for f in decode_frame(group_src).findings if f.code == "eth.src.group"]
    with pytest.raises(DecodeError, match="group address"):
        decode_frame(group_src, strict=True)


@pytest.mark.parametrize("line", COMMANDS)
def test_every_command_line_of_the_readme_runs(
    line: str, workdir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = shlex.split(line)[1:]
    if argv[0] == "serve" or "--iface" in argv:
        # runs only as root on a live link (test_live_soem, test_cli_live)
        build_parser().parse_args(argv)
        return
    old = Path.cwd()
    os.chdir(workdir)
    try:
        code = main(argv)
    finally:
        os.chdir(old)
    _, err = capsys.readouterr()
    assert code == EXIT.get(argv[0], 0), err
    assert "Traceback" not in err


def test_the_python_blocks_of_the_readme_run(workdir: Path) -> None:
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert len(blocks) >= 2
    old = Path.cwd()
    os.chdir(workdir)
    try:
        Path("x.pcapng").write_bytes(Path("capture.pcapng").read_bytes())
        names: dict[str, object] = {}  # one namespace: later blocks use earlier names (patch)
        for block in blocks:
            exec(compile(block, "README.md", "exec"), names)
    finally:
        os.chdir(old)
