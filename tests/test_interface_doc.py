"""docs/interface.md cannot drift from the command line: commands, options, choices, JSON keys.

Every command of ``build_parser()`` has a ``### `skinframes COMMAND` `` section; every option and
choice of the command is named in its section, and every ``--option`` the section names exists.
The JSON documents of real runs carry no key the section does not name.
"""

from __future__ import annotations

import argparse
import json
import re
import struct
from pathlib import Path
from typing import Any

import pytest

from emulator.epl.live import EplServeStats
from emulator.live import ServeStats
from emulator.net.can_bus import skin_bus
from skinframes import taxel
from skinframes.canbus.log import write_can_log
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, pcap_bytes
from skinframes_cli import build_parser, main

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "interface.md"
HEADING = re.compile(r"^### `skinframes ([a-z -]+)`$", re.MULTILINE)
OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")


def commands() -> dict[str, argparse.ArgumentParser]:
    """Every command path of the parser ("simulate", "can decode", ...) and its parser."""
    found: dict[str, argparse.ArgumentParser] = {}

    def walk(parser: argparse.ArgumentParser, path: tuple[str, ...]) -> None:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    found[" ".join((*path, name))] = sub
                    walk(sub, (*path, name))

    walk(build_parser(), ())
    return found


def sections() -> dict[str, str]:
    """The text of each command's section, keyed by command path."""
    text = DOC.read_text()
    marks = list(HEADING.finditer(text))
    out = {}
    for mark, after in zip(marks, [*marks[1:], None], strict=True):
        end = after.start() if after else text.find("\n## ", mark.end())
        out[mark.group(1)] = text[mark.end() : end if end != -1 else len(text)]
    return out


def options(parser: argparse.ArgumentParser) -> set[str]:
    return {
        s for a in parser._actions for s in a.option_strings if s.startswith("--") and s != "--help"
    }


def test_every_command_has_a_section_and_every_section_a_command() -> None:
    assert sorted(sections()) == sorted(commands())


@pytest.mark.parametrize("command", sorted(commands()))
def test_options_and_choices_of_a_command_are_documented(command: str) -> None:
    parser, text = commands()[command], sections()[command]
    named = set(OPTION.findall(text))
    own = options(parser) - options(build_parser())  # the global ones are the conventions'
    assert own <= named, f"undocumented: {sorted(own - named)}"
    unknown = named - options(parser) - options(build_parser()) - {"--help"}
    assert not unknown, f"the section names options {command} does not have: {sorted(unknown)}"
    for action in parser._actions:
        if action.choices and not isinstance(action, argparse._SubParsersAction):
            for choice in action.choices:
                assert re.search(rf"(?<![\w-]){re.escape(str(choice))}(?![\w-])", text), (
                    f"{command} {action.dest}: choice {choice!r} not documented"
                )


def test_global_options_are_documented() -> None:
    conventions = DOC.read_text().split("### ", 1)[0]
    assert options(build_parser()) <= set(OPTION.findall(conventions))
    for code in ("0", "1", "2", "130"):
        assert f"**{code}**" in conventions


# --- JSON keys ----------------------------------------------------------------------------------
def keys(doc: Any) -> set[str]:
    """Every key of a JSON document, nested ones too; keys that are data (numbers) left out."""
    if isinstance(doc, dict):
        own = {k for k in doc if not k.isdigit()}
        return own | {k for v in doc.values() for k in keys(v)}
    if isinstance(doc, list):
        return {k for v in doc for k in keys(v)}
    return set()


def assert_documented(command: str, found: set[str]) -> None:
    text = sections()[command]
    missing = {k for k in found if f'"{k}"' not in text and f"`{k}`" not in text}
    assert not missing, f"{command} --json keys missing from docs/interface.md: {sorted(missing)}"


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> list[Any]:
    assert main(list(argv)) == 0
    out = capsys.readouterr().out
    if argv[0] in ("decode", "can"):  # JSON Lines
        return [json.loads(line) for line in out.splitlines()]
    return [json.loads(out)]


@pytest.fixture(scope="module")
def can_trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    frames, _ = skin_bus([8, 9], taxel.contact_pattern(2, 2, seed=3), 50_000_000_000)
    path = tmp_path_factory.mktemp("doc") / "skin.log"
    write_can_log(path, frames)
    return path


@pytest.mark.parametrize(
    "argv",
    [
        ["tables", "--nodes", "2", "--bytes", "8", "--json"],
        ["simulate", "ecat", "--nodes", "3", "--bytes", "8", "--redundant", "--json"],
        ["simulate", "ecat", "--nodes", "3", "--bytes", "8", "--fault", "cable:1@1", "--json"],
        ["simulate", "epl", "--nodes", "3", "--bytes", "8", "--json"],
        ["plan", "--nodes", "3", "--bytes", "8", "--json"],
        ["check", str(ROOT / "pcaps" / "epl_asnd_services.pcap"), "--json"],
    ],
    ids=lambda argv: " ".join(argv[:2]),
)
def test_json_keys_are_documented(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    docs = run_json(capsys, *argv)
    assert_documented(argv[0], keys(docs))


def test_decode_json_keys_are_documented(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    can = tmp_path / "can.pcap"
    can.write_bytes(
        pcap_bytes(
            [(0, struct.pack(">IB3x", 0x410, 8) + bytes(8))], linktype=LINKTYPE_CAN_SOCKETCAN
        )
    )
    found: set[str] = set()
    for path in [*sorted((ROOT / "pcaps").glob("*.pcap")), can]:
        found |= keys(run_json(capsys, "decode", str(path), "--json"))
    assert {"datagrams", "message_type", "can_id"} <= found  # EtherCAT, EPL and CAN were seen
    assert_documented("decode", found)


def test_can_json_keys_are_documented(capsys: pytest.CaptureFixture[str], can_trace: Path) -> None:
    assert_documented(
        "can decode", keys(run_json(capsys, "can", "decode", str(can_trace), "--json"))
    )
    assert_documented("compare", keys(run_json(capsys, "compare", str(can_trace), "--json")))


def test_sii_json_keys_are_documented(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from emulator.slave.sii import SlaveInfo, build_sii

    image = tmp_path / "slave.bin"
    image.write_bytes(build_sii(SlaveInfo.skin_patch(16, mailbox=True, output_bytes=2)))
    found = keys(run_json(capsys, "sii", str(image), "--json"))
    assert {"syncmanagers", "txpdos", "rxpdos", "entries", "bits"} <= found
    # an ESI input adds "esi", with a modular device's slots and modules
    modular = ROOT / "tests" / "data" / "esi" / "modular_coupler.xml"
    found |= keys(run_json(capsys, "sii", str(modular), "--json"))
    assert {"esi", "slots", "modules", "module_idents", "depend_on_slot"} <= found
    assert_documented("sii", found)


def test_serve_json_keys_are_documented() -> None:
    # serve needs a live link; its document is these four plus the library's summary
    assert_documented("serve", {"protocol", "iface", "nodes", "bytes", *ServeStats().summary()})
    epl = {"node_ids", "error_messages", "counts", "cns", "node_id", "state", "state_changes"}
    assert_documented("serve", {*epl, *EplServeStats().summary()})
    mn = {"role", "cdc", "cycle_us", "cycles", "operational_cycles", "all_operational_s"}
    mn |= {"overruns", "frames_in", "frames_out", "errors", "error_messages", "counts", "pcap"}
    assert_documented("serve", mn)


def test_serve_epl_mn_json_keys_are_documented(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run of ``serve epl --mn`` against emulated CNs (a stand-in socket): every key of its
    document, the CNs' report and the counts they met included."""
    from epl_mn_util import SkinSocket

    import emulator.live
    from emulator.epl.skin import EplSkin

    monkeypatch.setattr(emulator.live, "RawSocket", lambda *a, **k: SkinSocket(EplSkin([1], 8)))
    argv = ["serve", "epl", "--mn", "--iface", "x", "--nodes", "1", "--bytes", "8"]
    assert_documented("serve", keys(run_json(capsys, *argv, "--cycles", "2", "--json")))


# --- Python names -------------------------------------------------------------------------------
def test_skinframes_package_names_are_documented() -> None:
    import skinframes

    text = DOC.read_text().split("## Python", 1)[1]
    missing = [n for n in [*skinframes.__all__, "__version__"] if f"`{n}`" not in text]
    assert not missing


EMULATOR_API = ("simulate_ecat", "simulate_epl", "SimResult", "PAPER", "WIRE", "TimingParams")


def test_emulator_package_exports_what_the_doc_promises() -> None:
    import emulator

    assert all(hasattr(emulator, name) for name in EMULATOR_API)
    text = DOC.read_text().split("## Python", 1)[1]
    assert [n for n in emulator.__all__ if f"`{n}`" not in text] == []
