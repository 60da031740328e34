"""A second, independent EtherCAT master: a minimal scan with hand-built raw frames.

It shares no code with skinframes or emulator: frames are packed here with ``struct`` from the
layouts of ETG.1000.4 (Tables 12/13) and the register map of the ESC datasheet section II; the
SII is walked as ETG.2010 describes it. It is the acceptance suite's cross-check of the chain
beyond SOEM's habits: its own station addresses (0x2000+), broadcast EEPROM reads, its own SM and
FMMU programming, and an LRD read of the inputs at logical address 0x00100000.

Run as a script it talks over a raw socket (``python tests/mini_master.py IFACE NODES``) and
prints one JSON document; :func:`scan` takes any ``transceive(frame) -> frame`` function.
"""

from __future__ import annotations

import json
import select
import socket
import struct
import sys
import time
from collections.abc import Callable
from typing import Any

ETHERTYPE = 0x88A4
SRC_MAC = bytes.fromhex("00005e005302")  # unicast, bit 0x02 clear (RFC 7042 documentation)
STATION_BASE = 0x2000
LOGICAL_BASE = 0x00100000
APRD, APWR, FPRD, FPWR, BRD, BWR, LRD = 0x01, 0x02, 0x04, 0x05, 0x07, 0x08, 0x0A

Transceive = Callable[[bytes], "bytes | None"]


class MasterError(AssertionError):
    """The slaves did not answer as ETG.1000 says they must."""


def frame(cmd: int, adp: int, ado: int, data: bytes, idx: int = 0x5A) -> bytes:
    """One datagram in one frame, padded to the 60-byte minimum."""
    dgram = struct.pack("<BBHHHH", cmd, idx, adp & 0xFFFF, ado & 0xFFFF, len(data), 0)
    dgram += data + b"\x00\x00"
    body = struct.pack("<H", len(dgram) | 0x1000) + dgram
    raw = b"\xff" * 6 + SRC_MAC + struct.pack(">H", ETHERTYPE) + body
    return raw + bytes(max(0, 60 - len(raw)))


def reply(raw: bytes | None, n: int) -> tuple[int, int, bytes, int]:
    """(cmd, adp, data, wkc) of the returned single-datagram frame."""
    if raw is None:
        raise MasterError("no reply")
    cmd, _idx, adp, _ado, length, _irq = struct.unpack_from("<BBHHHH", raw, 16)
    if length & 0x7FF != n:
        raise MasterError(f"reply length {length & 0x7FF}, sent {n}")
    data = raw[26 : 26 + n]
    (wkc,) = struct.unpack_from("<H", raw, 26 + n)
    return cmd, adp, bytes(data), wkc


class MiniMaster:
    """Register access helpers over ``transceive``."""

    def __init__(self, transceive: Transceive) -> None:
        self.tx = transceive

    def cmd(self, cmd: int, adp: int, ado: int, data: bytes) -> tuple[int, bytes, int]:
        sent = frame(cmd, adp, ado, data)
        back = self.tx(sent)
        if back is not None and len(back) != len(sent):
            raise MasterError(f"reply of {len(back)} bytes to a {len(sent)}-byte frame")
        if back is not None and back[6] != SRC_MAC[0] | 0x02:
            raise MasterError("the returned frame lacks the 0x02 source-MAC bit")
        _, adp_back, out, wkc = reply(back, len(data))
        return adp_back, out, wkc

    def fprd(self, station: int, ado: int, n: int) -> tuple[bytes, int]:
        _, data, wkc = self.cmd(FPRD, station, ado, bytes(n))
        return data, wkc

    def fpwr(self, station: int, ado: int, data: bytes) -> int:
        return self.cmd(FPWR, station, ado, data)[2]

    def eeprom_read(self, station: int, word: int) -> bytes:
        """8 bytes of SII from ``word`` (datasheet I 11.2.3 steps 1-9)."""
        for _ in range(100):
            status, _ = self.fprd(station, 0x0502, 2)
            if not struct.unpack("<H", status)[0] & 0x8000:
                break
        if self.fpwr(station, 0x0502, struct.pack("<HI", 0x0100, word)) != 1:
            raise MasterError(f"station {station:#x}: EEPROM command not accepted")
        for _ in range(100):
            status, _ = self.fprd(station, 0x0502, 2)
            (st,) = struct.unpack("<H", status)
            if not st & 0x8000:
                break
        if st & 0x6800:
            raise MasterError(f"station {station:#x}: EEPROM error status {st:#06x}")
        data, wkc = self.fprd(station, 0x0508, 8 if st & 0x0040 else 4)
        if wkc != 1:
            raise MasterError("EEPROM data not readable")
        return data

    def sii(self, station: int, max_bytes: int = 4096) -> bytes:
        """The SII up to its end category (ETG.2010: categories from word 0x40)."""
        image = bytearray()
        while len(image) < max_bytes:
            image += self.eeprom_read(station, len(image) // 2)
            if len(image) >= 0x84 and find_category(image, 0xFFFF) is not None:
                break
        return bytes(image)

    def wait_state(self, nodes: int, state: int) -> bytes:
        for _ in range(50):
            _, data, wkc = self.cmd(BRD, 0, 0x0130, bytes(2))
            if wkc == nodes and data[0] & 0x1F == state:
                return data
            time.sleep(0.001)
        raise MasterError(f"AL status {data.hex()} (WKC {wkc}), wanted state {state}")


def categories(image: bytes) -> list[tuple[int, bytes]]:
    """(type, data) of every SII category, from word 0x40 to the end marker."""
    out = []
    pos = 0x80
    while pos + 2 <= len(image):
        (kind,) = struct.unpack_from("<H", image, pos)
        if kind == 0xFFFF:
            out.append((kind, b""))
            break
        if pos + 4 > len(image):
            break
        (size,) = struct.unpack_from("<H", image, pos + 2)
        out.append((kind, bytes(image[pos + 4 : pos + 4 + 2 * size])))
        pos += 4 + 2 * size
    return out


def find_category(image: bytes, kind: int) -> bytes | None:
    for k, data in categories(image):
        if k == kind:
            return data
    return None


def scan(transceive: Transceive, nodes: int) -> dict[str, Any]:
    """Count, address, identify, configure and read ``nodes`` input-only slaves."""
    m = MiniMaster(transceive)
    result: dict[str, Any] = {}
    adp, data, count = m.cmd(BRD, 0, 0x0000, bytes(2))  # ESC type: WKC counts the slaves
    result["count"], result["brd_adp"], result["esc_type"] = count, adp, data[0]
    if count != nodes:
        raise MasterError(f"BRD counted {count} slaves, expected {nodes}")
    m.cmd(BWR, 0, 0x0120, struct.pack("<H", 0x0011))  # INIT + acknowledge
    for p in range(nodes):
        _, _, wkc = m.cmd(APWR, -p, 0x0010, struct.pack("<H", STATION_BASE + p))
        if wkc != 1:
            raise MasterError(f"APWR station of position {p}: WKC {wkc}")
    stations = [STATION_BASE + p for p in range(nodes)]
    result["stations"] = [struct.unpack("<H", m.fprd(s, 0x0010, 2)[0])[0] for s in stations]
    ident = []
    for s in stations:
        head = m.eeprom_read(s, 0x08) + m.eeprom_read(s, 0x0C)
        ident.append(struct.unpack("<IIII", head))
    result["identity"] = ident
    # broadcast EEPROM access: every slave loads the serial number, BRD ORs them together
    m.cmd(BWR, 0, 0x0502, struct.pack("<HI", 0x0100, 0x0E))
    _, ored, wkc = m.cmd(BRD, 0, 0x0508, bytes(4))
    result["broadcast_serial_or"], result["broadcast_wkc"] = struct.unpack("<I", ored)[0], wkc
    image = m.sii(stations[0])
    strings = find_category(image, 10) or b""
    names, pos = [], 1
    for _ in range(strings[0] if strings else 0):
        names.append(strings[pos + 1 : pos + 1 + strings[pos]].decode("ascii"))
        pos += 1 + strings[pos]
    general = find_category(image, 30) or bytes(32)
    result["name"] = names[general[3] - 1] if general[3] else ""
    syncm = find_category(image, 41) or b""
    sms = [struct.unpack_from("<HHBBBB", syncm, i) for i in range(0, len(syncm), 8)]
    txpdo = find_category(image, 50) or b""
    bits, pos, sm_of_pdo = 0, 0, None
    while pos < len(txpdo):
        _index, n_entries, sm_of_pdo = struct.unpack_from("<HBB", txpdo, pos)
        pos += 8
        for _ in range(n_entries):
            bits += txpdo[pos + 5]
            pos += 8
    size = (bits + 7) // 8
    result["input_bytes"], result["sii_bytes"] = size, len(image)
    if sm_of_pdo is None:
        raise MasterError("no TxPDO in the SII")
    start, _len, control, _st, enable, kind = sms[sm_of_pdo]
    result["sm"] = [start, size, control, enable, kind]
    for s in stations:  # mailbox SyncManagers (SII types 1, 2) before PREOP
        for i, (m_start, m_len, m_control, _st, m_enable, m_kind) in enumerate(sms):
            if m_kind in (1, 2):
                regs = struct.pack("<HHBBBB", m_start, m_len, m_control, 0, m_enable, 0)
                if m.fpwr(s, 0x0800 + 8 * i, regs) != 1:
                    raise MasterError(f"station {s:#x}: mailbox SM write refused")
    m.cmd(BWR, 0, 0x0120, struct.pack("<H", 0x0002))
    m.wait_state(nodes, 0x02)
    for p, s in enumerate(stations):
        sm_regs = struct.pack("<HHBBBB", start, size, control, 0, enable, 0)
        if m.fpwr(s, 0x0800 + 8 * sm_of_pdo, sm_regs) != 1:
            raise MasterError(f"station {s:#x}: SM write refused")
        fmmu = struct.pack("<IHBBHBBB3x", LOGICAL_BASE + p * size, size, 0, 7, start, 0, 1, 1)
        if m.fpwr(s, 0x0600, fmmu) != 1:
            raise MasterError(f"station {s:#x}: FMMU write refused")
    for state in (0x04, 0x08):
        m.cmd(BWR, 0, 0x0120, struct.pack("<H", state))
        result[f"al_status_{state}"] = m.wait_state(nodes, state).hex()
    per = max(1, 1486 // size)  # whole slaves per datagram
    inputs, wkcs = b"", []
    for first in range(0, nodes, per):
        k = min(per, nodes - first)
        lad = LOGICAL_BASE + first * size
        _, data, wkc = m.cmd(LRD, lad & 0xFFFF, lad >> 16, bytes(k * size))
        inputs += data
        wkcs.append(wkc)
    result["lrd_wkc"], result["inputs"] = wkcs, inputs.hex()
    m.cmd(BWR, 0, 0x0120, struct.pack("<H", 0x0001))
    result["al_status_final"] = m.wait_state(nodes, 0x01).hex()
    return result


def socket_transceive(iface: str, timeout_s: float = 5.0) -> Transceive:
    """Send on a raw AF_PACKET socket and wait for the frame that comes back (no answer is an
    error, so the wait is long: a busy machine slows the test, never fails it)."""
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETHERTYPE))
    sock.bind((iface, ETHERTYPE))

    def tx(raw: bytes) -> bytes | None:
        sock.send(raw)
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            if not select.select([sock], [], [], left)[0]:
                break
            data, addr = sock.recvfrom(2048)
            if addr[2] != 4 and data[6:12] != SRC_MAC:  # skip our own frame (PACKET_OUTGOING)
                return data
        return None

    return tx


if __name__ == "__main__":
    print(json.dumps(scan(socket_transceive(sys.argv[1]), int(sys.argv[2]))))
