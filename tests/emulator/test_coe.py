"""Mailbox and CoE of the emulated skin patch, byte by byte against ETG.1000.4/.6.

Every mailbox message below is written out by hand from the spec's tables (mailbox header
ETG.1000.4 Table 29, CoE header ETG.1000.6 Table 35, SDO command bytes 5.6.2, SDO information
Table 43, emergency 5.6.4, abort codes Table 41) and travels through the emulated chain in
FPWR/FPRD datagrams as a master sends them; the answers are compared byte for byte. A capture of
such an exchange is judged by tshark.
"""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
import tshark_util

from emulator.esc.chain import EcatChain
from emulator.slave.sii import SlaveInfo, build_sii
from skinframes import ethercat
from skinframes.capture_writer import write_pcap
from skinframes.ethercat import Command as C  # noqa: N817
from skinframes.ethercat import Datagram, EcatFrame

STATION = 0x1001
MBX_OUT, MBX_IN, MBX_BYTES = 0x1000, 0x1080, 128
VENDOR_LE = bytes.fromhex("4e494b53")  # 0x534B494E ("SKIN") little-endian


def h(text: str) -> bytes:
    """Hex with spaces for readability."""
    return bytes.fromhex(text.replace(" ", ""))


class Master:
    """Just enough of a master: datagrams through the chain, every frame kept for tshark."""

    def __init__(self, chain: EcatChain) -> None:
        self.chain = chain
        self.frames: list[bytes] = []

    def one(self, d: Datagram) -> Datagram:
        sent = ethercat.frame(EcatFrame((d,))).to_bytes()
        back = self.chain.process_frame(sent)
        assert back is not None
        self.frames += [sent, back]
        ecat, _, _ = ethercat.decode(back[14:], strict=False)
        return ecat.datagrams[0]

    def wr(self, ado: int, data: bytes, station: int = STATION) -> int:
        return self.one(Datagram(C.FPWR, station, ado, data)).wkc

    def rd(self, ado: int, n: int, station: int = STATION) -> Datagram:
        return self.one(Datagram(C.FPRD, station, ado, bytes(n)))

    def send(self, message: bytes) -> int:
        """Write a whole mailbox (the ESC needs its end address written)."""
        return self.wr(MBX_OUT, message + bytes(MBX_BYTES - len(message)))

    def receive(self) -> bytes | None:
        """Read SM1 if the slave filled it: the message up to its header's length."""
        if not self.rd(0x080D, 1).data[0] & 0x08:
            return None
        d = self.rd(MBX_IN, MBX_BYTES)
        assert d.wkc == 1
        (length,) = struct.unpack_from("<H", d.data)
        return d.data[: 6 + length]

    def state(self, value: int) -> int:
        self.one(Datagram(C.BWR, 0, 0x0120, struct.pack("<H", value)))
        return int.from_bytes(self.rd(0x0130, 2).data, "little")


def preop(input_bytes: int = 192, nodes: int = 1) -> Master:
    """Station addresses, SM0/SM1 as the SII says (SOEM's one 16-byte FPWR), then PREOP."""
    m = Master(EcatChain.skin(nodes, input_bytes, mailbox=True))
    for p in range(nodes):
        m.one(Datagram(C.APWR, (-p) & 0xFFFF, 0x0010, struct.pack("<H", STATION + p)))
        # SM0: 0x1000, 128, control 0x26, enable; SM1: 0x1080, 128, control 0x22, enable
        assert m.wr(0x0800, h("0010 8000 26 00 01 00  8010 8000 22 00 01 00"), STATION + p) == 1
    assert m.state(0x02) == 0x02
    return m


# --- SII -------------------------------------------------------------------------------------
def test_sii_tells_masters_where_the_mailbox_is() -> None:
    image = build_sii(SlaveInfo.skin_patch(192, mailbox=True))
    # ETG.2010 Table 2: words 0x18-0x1B receive/send mailbox offset and size, 0x1C protocols
    assert image[2 * 0x18 : 2 * 0x1D] == h("0010 8000 8010 8000 0400")  # CoE = bit 2
    at, general, syncm = 2 * 0x40, b"", b""
    while (kind := int.from_bytes(image[at : at + 2], "little")) != 0xFFFF:
        words = int.from_bytes(image[at + 2 : at + 4], "little")
        body = image[at + 4 : at + 4 + 2 * words]
        general = body if kind == 30 else general
        syncm = body if kind == 41 else syncm
        at += 4 + 2 * words
    assert general[5] == 0x27  # CoE details: SDO, SDO info, PDO assign, complete access
    assert syncm == h(
        "0010 8000 26 00 01 01"  # SM0 mailbox out (type 1)
        "8010 8000 22 00 01 02"  # SM1 mailbox in (type 2)
        "0011 0000 64 00 00 03"  # SM2 outputs: none, disabled (type 3)
        "0011 c000 20 00 01 04"  # SM3 inputs, 192 bytes (type 4)
    )


def test_preop_needs_the_mailbox_configured() -> None:
    m = Master(EcatChain.skin(1, 192, mailbox=True))
    m.one(Datagram(C.APWR, 0, 0x0010, struct.pack("<H", STATION)))
    assert m.state(0x02) == 0x11  # stays INIT with the error indication
    assert m.rd(0x0134, 2).data == h("1600")  # 0x0016 invalid mailbox configuration
    # SM0/SM1 are not enabled: 0x1000 is plain memory, nobody answers
    assert m.send(h("0a00 0000 00 13  0020  40 1810 01 00000000")) == 1
    assert m.receive() is None


# --- SDO upload -----------------------------------------------------------------------------
def test_expedited_upload_of_the_vendor_id() -> None:
    m = preop()
    # header: length 10, address 0, channel/priority 0, type 3 (CoE) | counter 1 << 4
    # CoE: service 2 (SDO request) << 12; command 0x40 upload initiate; 0x1018:01; 4 reserved
    assert m.send(h("0a00 0000 00 13  0020  40 1810 01 00000000")) == 1
    assert m.rd(0x080D, 1).data[0] & 0x08  # SM1 status: mailbox full
    # answer: counter 1, CoE service 3 (SDO response); 0x43 = upload initiate response,
    # expedited, size indicated, 4 bytes (n = 0); the vendor ID little-endian
    assert m.receive() == h("0a00 0000 00 13  0030  43 1810 01") + VENDOR_LE
    assert not m.rd(0x080D, 1).data[0] & 0x08  # read to the end: empty again
    assert m.rd(MBX_IN, MBX_BYTES).wkc == 0  # "read w. failure (mailbox empty)"


def test_a_repeated_counter_is_a_repetition_not_a_new_request() -> None:
    m = preop()
    request = h("0a00 0000 00 23  0020  40 1810 02 00000000")  # counter 2: 0x1018:02
    assert m.send(request) == 1
    assert m.receive() == h("0a00 0000 00 13  0030  43 1810 02 c0000100")  # product 0x100C0
    assert m.send(request) == 1  # the master repeats it (its first WKC was lost)
    assert m.receive() is None  # dropped: same counter as the message before
    assert m.send(h("0a00 0000 00 33  0020  40 1810 04 00000000")) == 1  # counter 3: new
    assert m.receive() == h("0a00 0000 00 23  0030  43 1810 04 01000000")  # serial 1


def test_normal_upload_of_a_string() -> None:
    m = preop()
    assert m.send(h("0a00 0000 00 13  0020  40 0810 00 00000000")) == 1  # 0x1008 device name
    name = b"SkinPatch192"
    # 0x41: upload initiate response, size indicated, not expedited; size 12, then the data
    assert m.receive() == h("1600 0000 00 13  0030  41 0810 00 0c000000") + name


def test_segmented_upload_with_complete_access() -> None:
    m = preop(1486)  # 124 triangles: 0x1C13 holds 124 PDO numbers
    assign = bytes([124, 0]) + b"".join(struct.pack("<H", 0x1A00 + t) for t in range(124))
    assert len(assign) == 250
    # 0x50: upload initiate with complete access (bit 4), from subindex 0
    assert m.send(h("0a00 0000 00 13  0020  50 131c 00 00000000")) == 1
    # 0x51: normal response, complete access, size 250, then 128 - 6 - 10 = 112 data bytes
    first = m.receive()
    assert first == h("7a00 0000 00 13  0030  51 131c 00 fa000000") + assign[:112]
    # upload segment request 0x60 (toggle 0); answer 0x00: toggle 0, more follow, 119 bytes
    assert m.send(h("0a00 0000 00 23  0020  60 00000000000000")) == 1
    assert m.receive() == h("7a00 0000 00 23  0030  00") + assign[112:231]
    # toggle 1 (0x70); the last 19 bytes: 0x11 = toggle | last segment, length 3 + 19
    assert m.send(h("0a00 0000 00 33  0020  70 00000000000000")) == 1
    assert m.receive() == h("1600 0000 00 33  0030  11") + assign[231:]
    # the same toggle twice is an error: abort 0x05030000 (toggle bit not alternated)
    assert m.send(h("0a00 0000 00 43  0020  50 131c 00 00000000")) == 1
    assert m.receive() is not None
    assert m.send(h("0a00 0000 00 53  0020  70 00000000000000")) == 1
    assert m.receive() == h("0a00 0000 00 53  0020  80 131c 00 00000305")


# --- SDO download ---------------------------------------------------------------------------
def test_expedited_download_and_its_aborts() -> None:
    m = preop()
    # 0x2f: download initiate, n = 3 (one data byte), expedited, size indicated: 0x8000:02 = 5
    assert m.send(h("0a00 0000 00 13  0020  2f 0080 02 05000000")) == 1
    assert m.receive() == h("0a00 0000 00 13  0030  60 0080 02 00000000")
    assert m.send(h("0a00 0000 00 23  0020  40 0080 02 00000000")) == 1
    assert m.receive() == h("0a00 0000 00 23  0030  4f 0080 02 05000000")  # n = 3: one byte
    # aborts (command 0x80, service 2 "SDO request" as ETG.1000.6 5.6.2.7 sends them)
    cases = [
        ("0a00 0000 00 33  0020  40 0020 00 00000000", "0020 00 00000206"),  # no object 0x2000
        ("0a00 0000 00 43  0020  40 1810 09 00000000", "1810 09 11000906"),  # no subindex
        ("0a00 0000 00 53  0020  23 1810 01 00000000", "1810 01 02000106"),  # read only
        ("0a00 0000 00 63  0020  2b 0080 02 0500 0000", "0080 02 10000706"),  # 2 bytes to a u8
        ("0a00 0000 00 73  0020  23 0080 01 01000000", "0080 01 32000906"),  # 1 us: too low
        ("0a00 0000 00 13  0020  2b 131c 01 001a0000", "131c 01 03000106"),  # SI0 must be 0
        ("0a00 0000 00 23  0020  a0 0010 00 00000000", "0010 00 01000405"),  # bad command
    ]
    for request, answer in cases:
        counter = request[13:15]
        assert m.send(h(request)) == 1
        assert m.receive() == h(f"0a00 0000 00 {counter}  0020  80 {answer}"), request


def test_pdo_assignment_only_in_preop_and_segmented_download() -> None:
    m = preop(1486)
    pdos = [0x1A00 + t for t in reversed(range(124))]
    data = bytes([124, 0]) + b"".join(struct.pack("<H", p) for p in pdos)
    # 0x31: download initiate, complete access, size indicated, normal: size 250 + 112 bytes
    assert m.send(h("7a00 0000 00 13  0020  31 131c 00 fa000000") + data[:112]) == 1
    assert m.receive() == h("0a00 0000 00 13  0030  70 131c 00 00000000")  # 0x60 | CA
    # download segment 0x00 (toggle 0, more): 119 bytes; answer 0x20 (toggle 0)
    assert m.send(h("7a00 0000 00 23  0020  00") + data[112:231]) == 1
    assert m.receive() == h("0a00 0000 00 23  0030  20 00000000000000")
    # 0x11: toggle 1, last segment, 19 bytes; answer 0x30
    assert m.send(h("1600 0000 00 33  0020  11") + data[231:]) == 1
    assert m.receive() == h("0a00 0000 00 33  0030  30 00000000000000")
    assert m.send(h("0a00 0000 00 43  0020  40 131c 01 00000000")) == 1
    assert m.receive() == h("0a00 0000 00 43  0030  4b 131c 01 7b1a0000")  # 0x1A7B first now
    # SAFE-OP: the assignment is read-only now, abort 0x08000022 (device state)
    m.wr(0x0818, h("0011 0000 64 00 00 00"))  # SM3 length: the assigned 124 x 12 bytes
    m.wr(0x0818, struct.pack("<HHBBBB", 0x1100, 1486, 0x20, 0, 1, 0))
    assert m.state(0x04) == 0x04
    assert m.send(h("0a00 0000 00 53  0020  2f 131c 00 00000000")) == 1
    assert m.receive() == h("0a00 0000 00 53  0020  80 131c 00 22000008")


def test_reassigned_pdos_shrink_the_process_image() -> None:
    m = preop()
    # SI0 = 0, entry 1 = 0x1A05, entry 2 = 0x1A02, SI0 = 2 (expedited writes)
    for counter, request in (
        ("13", "2f 131c 00 00000000"),
        ("23", "2b 131c 01 051a0000"),
        ("33", "2b 131c 02 021a0000"),
        ("43", "2f 131c 00 02000000"),
    ):
        assert m.send(h(f"0a00 0000 00 {counter}  0020 {request}")) == 1
        answer = m.receive()
        assert answer is not None and answer[8] == 0x60, answer.hex()
    m.wr(0x0818, struct.pack("<HHBBBB", 0x1100, 192, 0x20, 0, 1, 0))  # the SII's 192 bytes
    assert m.state(0x04) == 0x12  # refused (PREOP, error): 0x001E invalid input configuration
    assert m.rd(0x0134, 2).data == h("1e00")
    # the refusal comes as an emergency: CoE service 1, code 0xA000, error register bit 0,
    # data = AL status code 0x001E, current state 2, requested state 4
    assert m.receive() == h("0a00 0000 00 53  0010  00a0 01 1e00 02 04 00")  # 5th message
    m.wr(0x081E, b"\x00")  # disable SM3: its configuration changes only while disabled
    m.wr(0x0818, struct.pack("<HHBBBB", 0x1100, 24, 0x20, 0, 1, 0))  # two triangles
    assert m.state(0x14) == 0x04  # acknowledged and accepted
    m.chain.publish([bytes(range(192))])
    assert m.rd(0x1100, 24).data == bytes(range(60, 72)) + bytes(range(24, 36))


# --- SDO information ------------------------------------------------------------------------
def test_sdo_information_lists_and_describes_the_dictionary() -> None:
    m = preop()
    # CoE service 8; opcode 1 (get OD list), reserved, fragments left 0; list type 1 (all)
    assert m.send(h("0800 0000 00 13  0080  01 00 0000  0100")) == 1
    objects = [0x1000, 0x1001, 0x1008, 0x1009, 0x100A, 0x1018]
    objects += [0x1A00 + t for t in range(16)] + [0x1C00, 0x1C12, 0x1C13]
    objects += [0x6000 + t for t in range(16)] + [0x8000]
    body = h("0080 02 00 0000 0100") + b"".join(struct.pack("<H", i) for i in objects)
    assert m.receive() == struct.pack("<HHBB", len(body), 0, 0, 0x13) + body
    # opcode 3: object description of 0x1018: data type 0x0023, max subindex 4, RECORD (9)
    assert m.send(h("0800 0000 00 23  0080  03 00 0000  1810")) == 1
    assert m.receive() == h("1400 0000 00 23  0080 04 00 0000  1810 2300 04 09") + b"Identity"
    # opcode 5: entry 0x1018:01 with access/category/PDO info (7): UNSIGNED32, 32 bits, RO
    assert m.send(h("0a00 0000 00 33  0080  05 00 0000  1810 01 07")) == 1
    assert m.receive() == h("1900 0000 00 33  0080 06 00 0000  1810 01 07 0700 2000 0700") + (
        b"Vendor ID"
    )
    # a taxel: UNSIGNED8, 8 bits, readable in PREOP/SAFEOP/OP and TxPDO-mappable (0x87)
    assert m.send(h("0a00 0000 00 43  0080  05 00 0000  0560 0c 07")) == 1
    assert m.receive() == h("1c00 0000 00 43  0080 06 00 0000  0560 0c 07 0500 0800 8700") + (
        b"SubIndex 012"
    )
    # an unknown object: SDO information error (opcode 7) with abort code 0x06020000
    assert m.send(h("0800 0000 00 53  0080  03 00 0000  0020")) == 1
    assert m.receive() == h("0a00 0000 00 53  0080 07 00 0000  00000206")


def test_a_long_object_list_comes_in_fragments() -> None:
    m = preop(1486)  # 10 + 2 x 124 objects
    assert m.send(h("0800 0000 00 13  0080  01 00 0000  0100")) == 1
    payload = b""
    fragments = []
    while (msg := m.receive()) is not None:
        opcode, _, left = struct.unpack_from("<BBH", msg, 8)
        fragments.append((opcode, left))
        payload += msg[12:]
    count = 10 + 2 * 124
    assert len(payload) == 2 + 2 * count
    # 116 bytes a message: 5 fragments, incomplete bit 0x80 on all but the last, counting down
    assert fragments == [(0x82, 4), (0x82, 3), (0x82, 2), (0x82, 1), (0x02, 0)]
    assert payload[:2] == h("0100")


# --- mailbox link layer ---------------------------------------------------------------------
def test_repeat_request_puts_the_last_answer_back() -> None:
    m = preop()
    assert m.send(h("0a00 0000 00 13  0020  40 1810 01 00000000")) == 1
    answer = m.receive()
    assert answer is not None  # ...but say the returning frame was lost: ask for a repeat
    assert m.rd(0x080F, 1).data[0] & 0x02 == 0  # repeat acknowledge = repeat = 0
    status = m.rd(0x080D, 2).data  # SOEM: FPWR 0x080D with 0x080E bit 1 toggled
    assert m.wr(0x080D, bytes([status[0], status[1] ^ 0x02])) == 1
    assert m.rd(0x080F, 1).data[0] & 0x02 == 0x02  # acknowledged
    assert m.receive() == answer  # the same message, the same counter


def test_a_repeat_request_broadcast_to_a_line_is_acknowledged_by_every_slave() -> None:
    """A BWR of SM1's activate byte with the repeat bit set (0x080E bit 1) reaches 6 slaves,
    whose ESCs commit it together: after the frame each slave's mailbox handler sees the
    request and acknowledges it in its PDI control byte (0x080F bit 1, datasheet II 2.14.7)."""
    m = preop(nodes=6)
    assert m.one(Datagram(C.BWR, 0, 0x080E, b"\x03")).wkc == 6
    for p in range(6):
        assert m.rd(0x080F, 1, STATION + p).data[0] & 0x02 == 0x02, p


def test_a_repeat_request_in_a_write_that_enables_a_syncmanager_is_acknowledged() -> None:
    """The same request in a BWR that also enables SM2 (0x0810-0x0817: 8 bytes at 0x1100), so
    that each ESC's SyncManager table changes and the 6 ESCs change their SyncManagers
    together: after the frame each slave's mailbox handler still sees the request and
    acknowledges it."""
    m = preop(nodes=6)
    sm2 = struct.pack("<HHBBBB", 0x1100, 8, 0x64, 0, 0x01, 0)
    assert m.one(Datagram(C.BWR, 0, 0x080E, b"\x03\x00" + sm2)).wkc == 6
    for p in range(6):
        assert m.rd(0x0816, 1, STATION + p).data[0] & 0x01 == 0x01, p  # SM2 enabled
        assert m.rd(0x080F, 1, STATION + p).data[0] & 0x02 == 0x02, p


def test_other_protocols_get_a_mailbox_error() -> None:
    m = preop()
    assert m.send(h("0600 0000 00 14  01 00 0000 0000")) == 1  # type 4 (FoE), counter 1
    # type 0 (error), command 0x0001, detail 0x0002 "unsupported protocol" (ETG.1000.6 T30)
    assert m.receive() == h("0400 0000 00 10  0100 0200")


def test_init_locks_the_mailbox_again() -> None:
    m = preop()
    assert m.state(0x01) == 0x01
    assert m.send(h("0a00 0000 00 13  0020  40 1810 01 00000000")) == 0  # SM0 locked


# --- tshark ---------------------------------------------------------------------------------
@pytest.mark.tshark
def test_tshark_decodes_the_exchange(tshark: str, tmp_path: Path) -> None:
    m = preop(1486)
    assert m.send(h("0a00 0000 00 13  0020  40 1810 01 00000000")) == 1
    m.receive()
    assert m.send(h("0a00 0000 00 23  0020  50 131c 00 00000000")) == 1
    m.receive()
    for counter, toggle in (("33", "60"), ("43", "70")):
        assert m.send(h(f"0a00 0000 00 {counter}  0020  {toggle} 00000000000000")) == 1
        m.receive()
    assert m.send(h("0a00 0000 00 53  0020  40 0020 00 00000000")) == 1
    m.receive()
    path = tmp_path / "coe.pcap"
    write_pcap(path, [(k * 10_000, f) for k, f in enumerate(m.frames)])
    assert tshark_util.problems(tshark, path) == []
    rows = tshark_util.fields(
        tshark,
        path,
        [
            "ecat_mailbox.counter",
            "ecat_mailbox.coe.type",
            "ecat_mailbox.coe.sdoidx",
            "ecat_mailbox.coe.sdodata",
            "ecat_mailbox.coe.sdolength",
            "ecat_mailbox.coe.sdoscsus_lastseg",
            "ecat_mailbox.coe.abortcode",
            "ecat.cnt",
        ],
        "ecat_mailbox && ecat.cmd == 4",  # the answers read from SM1
    )
    got = [
        {k.rsplit(".", 1)[1]: v for k, v in r.items() if v and not k.endswith("cnt")} for r in rows
    ]
    assert got == [
        {"counter": ["1"], "type": ["3"], "sdoidx": ["0x1018"], "sdodata": ["0x534b494e"]},
        {"counter": ["2"], "type": ["3"], "sdoidx": ["0x1c13"], "sdolength": ["0x000000fa"]},
        {"counter": ["3"], "type": ["3"], "sdoscsus_lastseg": ["0"]},
        {"counter": ["4"], "type": ["3"], "sdoscsus_lastseg": ["1"]},
        {"counter": ["5"], "type": ["2"], "abortcode": ["0x06020000"]},
    ]
