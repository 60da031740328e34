"""Live capture from a Linux network interface: the records ``decode``, ``check`` and ``analyze``
read from a file, read from the wire instead.

How, and why this way:

- An AF_PACKET raw socket (``packet(7)``), as ``serve`` uses (:mod:`emulator.live`), with no
  dependency and nothing to install: libpcap has no binding in the environment (pcapy,
  pypcap) and ``dumpcap`` would add a process, a pipe and Wireshark's capture group. The
  socket needs root or CAP_NET_RAW; it is Linux only, as ``serve`` is.
- A capture filter in the kernel (classic BPF, ``SO_ATTACH_FILTER``; :func:`capture_filter`)
  keeps other traffic out before it is copied to us: EtherCAT (EtherType 0x88A4), EPL (0x88AB),
  each also behind one or two VLAN tags (0x8100, 0x88A8, 0x9100), and IPv4 UDP datagrams from or
  to port 3819 (EPL over UDP) or 0x88A4 (EtherCAT over UDP), unfragmented or first fragments.
  It is attached before the socket is bound to the interface, so no frame passes unfiltered.
- Frames in both directions, as tshark captures them: on a master's interface the frames it
  sends and the frames that return (``analyze`` pairs them into round trips).
- Times are the kernel's receive stamps (``SO_TIMESTAMPNS``), nanoseconds since the epoch.
- VLAN tags the kernel took off the frame (VLAN acceleration; the tag is then in
  ``PACKET_AUXDATA``) are put back where they were, as libpcap puts them back.
- What the kernel dropped because we read too slowly (``PACKET_STATISTICS``) is reported as a
  finding of the capture (``live.dropped``, a warning), so ``check`` lists it and ``decode``
  prints it.

A capture ends after ``duration_s`` seconds, after ``count`` frames, when ``stop()`` is called,
or (in the main thread) at SIGINT: Ctrl-C ends it as the end of a file would, and what was
captured is reported as usual. At the end (time or stop), the frames the kernel stamped before
that moment and still waiting in the socket are read; later ones are not.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import select
import signal
import socket
import struct
import sys
import threading
import time
from collections.abc import Generator, Iterator
from pathlib import Path
from types import FrameType
from typing import Final

from skinframes.errors import InterfaceError
from skinframes.ethernet import ETHERTYPE_ECAT, ETHERTYPE_EPL
from skinframes.findings import FrameFinding, warning
from skinframes.ipv4udp import ETHERTYPE_IPV4, PROTO_UDP, UDP_PORT_ECAT, UDP_PORT_EPL
from skinframes.pcap import LINKTYPE_ETHERNET, Record, Skipped
from skinframes.vlan import TAG_BYTES, TPID_CTAG, TPIDS

__all__ = ["CAPTURED_ETHERTYPES", "CAPTURED_UDP_PORTS", "LiveCapture", "capture_filter"]

CAPTURED_ETHERTYPES: Final = (ETHERTYPE_ECAT, ETHERTYPE_EPL)
CAPTURED_UDP_PORTS: Final = (UDP_PORT_EPL, UDP_PORT_ECAT)
SNAPLEN: Final = 65535  # bytes kept of a frame (more than any Ethernet frame)
POLL_S: Final = 0.1  # the longest wait between looks at the stop conditions

# linux/if_ether.h, linux/if_packet.h, asm-generic/socket.h, linux/filter.h
ETH_P_ALL: Final = 0x0003
SOL_PACKET: Final = 263
PACKET_STATISTICS: Final = 6
PACKET_AUXDATA: Final = 8
TP_STATUS_VLAN_VALID: Final = 0x10
TP_STATUS_VLAN_TPID_VALID: Final = 0x40
SO_ATTACH_FILTER: Final = 26
SO_TIMESTAMPNS: Final = 35
SO_RCVBUFFORCE: Final = 33
SOCKET_BUFFER_BYTES: Final = 1 << 24
_AUXDATA: Final = struct.Struct("=IIIHHHH")  # tpacket_auxdata
_TIMESPEC: Final = struct.Struct("=qq")
_STATS: Final = struct.Struct("=II")  # tpacket_stats: tp_packets, tp_drops

# classic BPF opcodes (linux/bpf_common.h)
_LDH_ABS: Final = 0x28  # A = u16 at [k]
_LDB_ABS: Final = 0x30  # A = u8 at [k]
_LDH_IND: Final = 0x48  # A = u16 at [X + k]
_LDX_MSH: Final = 0xB1  # X = 4 * ([k] & 0xF), the IPv4 header length
_JEQ: Final = 0x15
_JSET: Final = 0x45
_JA: Final = 0x05
_RET: Final = 0x06
_ETHERTYPE_AT: Final = 12
_HEADER_BYTES: Final = 14
_IPV4_PROTO_AT: Final = 9
_IPV4_FRAG_AT: Final = 6
_IPV4_FRAGMENT_OFFSET: Final = 0x1FFF


def capture_filter() -> list[tuple[int, int, int, int]]:
    """The kernel's capture filter (classic BPF ``(code, jt, jf, k)`` instructions): accept
    EtherCAT, EPL and their UDP/IPv4 encapsulations, also behind one or two VLAN tags; refuse
    every other frame (see the module)."""
    prog: list[tuple[int, str | int, str | int, int]] = []
    labels: dict[str, int] = {}

    def at(label: str) -> None:
        labels[label] = len(prog)

    def jeq(k: int, yes: str) -> None:  # if A == k goto yes, else next
        prog.append((_JEQ, yes, 0, k))

    def goto(label: str) -> None:  # jump always (JA: its offset in k)
        prog.append((_JA, label, 0, 0))

    # EtherType, behind up to two tags: ethertype at 12, 16 or 20, payload at 14, 18 or 22
    for tags in range(3):
        at(f"type{tags}")
        prog.append((_LDH_ABS, 0, 0, _ETHERTYPE_AT + TAG_BYTES * tags))
        if tags < 2:
            for tpid in sorted(TPIDS):
                jeq(tpid, f"type{tags + 1}")
        for ethertype in CAPTURED_ETHERTYPES:
            jeq(ethertype, "accept")
        jeq(ETHERTYPE_IPV4, f"ipv4_{tags}")
        goto("reject")
    for tags in range(3):
        base = _HEADER_BYTES + TAG_BYTES * tags
        at(f"ipv4_{tags}")
        prog.append((_LDB_ABS, 0, 0, base + _IPV4_PROTO_AT))
        prog.append((_JEQ, 0, "reject", PROTO_UDP))
        prog.append((_LDH_ABS, 0, 0, base + _IPV4_FRAG_AT))
        prog.append((_JSET, "reject", 0, _IPV4_FRAGMENT_OFFSET))  # a later fragment: no ports
        prog.append((_LDX_MSH, 0, 0, base))
        for port_at in (0, 2):  # source port, destination port
            prog.append((_LDH_IND, 0, 0, base + port_at))
            for port in CAPTURED_UDP_PORTS:
                jeq(port, "accept")
        goto("reject")
    at("accept")
    prog.append((_RET, 0, 0, SNAPLEN))
    at("reject")
    prog.append((_RET, 0, 0, 0))

    out: list[tuple[int, int, int, int]] = []
    for i, (code, jt, jf, k) in enumerate(prog):

        def rel(target: str | int, at: int = i) -> int:
            return labels[target] - at - 1 if isinstance(target, str) else target

        if code == _JA:
            out.append((code, 0, 0, rel(jt)))
        else:
            out.append((code, rel(jt), rel(jf), k))
    if any(not 0 <= jt <= 255 or not 0 <= jf <= 255 for _, jt, jf, _ in out):
        raise AssertionError("a capture filter jump beyond 255 instructions")  # pragma: no cover
    return out


def _attach_filter(sock: socket.socket, program: list[tuple[int, int, int, int]]) -> None:
    insns = (ctypes.c_uint8 * (8 * len(program)))()
    for i, (code, jt, jf, k) in enumerate(program):
        struct.pack_into("=HBBI", insns, 8 * i, code, jt, jf, k)
    fprog = struct.pack("=HxxxxxxQ" if struct.calcsize("P") == 8 else "=HxxI",
                        len(program), ctypes.addressof(insns))  # fmt: skip
    sock.setsockopt(socket.SOL_SOCKET, SO_ATTACH_FILTER, fprog)


def _if_speed_bps(iface: str) -> int | None:
    """The link's speed (``/sys/class/net/IF/speed``, Mbit/s), None when it does not say."""
    try:
        mbps = int(Path(f"/sys/class/net/{iface}/speed").read_text().strip())
    except (OSError, ValueError):
        return None
    return mbps * 1_000_000 if mbps > 0 else None


class LiveCapture:
    """The frames on ``iface`` as :class:`~skinframes.pcap.Record` s, read once, as they come.

    It answers what :class:`~skinframes.pcap.Capture` answers (``path``, ``format``,
    ``skipped``, ``findings``, ``total``), so ``check_capture`` and ``analyze_capture`` read it
    as they read a file. The socket opens when the object is made, so that a missing interface
    or missing privileges are an error before anything is printed.

    Args:
        iface: the network interface.
        duration_s: stop after this many seconds (None: no limit).
        count: stop after this many frames (None: no limit).

    Raises:
        InterfaceError: no such interface, no privileges, no AF_PACKET.
    """

    def __init__(
        self, iface: str, *, duration_s: float | None = None, count: int | None = None
    ) -> None:
        self.iface = iface
        self.path = f"{iface} (live)"
        self.format = "live"
        self.duration_s = duration_s
        self.count = count
        self.frames = 0
        self.dropped = 0
        self.seconds = 0.0
        self.interrupted = False
        self._stop = threading.Event()
        self._stop_ns = 0
        self._done = False
        self._if_speed = _if_speed_bps(iface)
        self.sock = self._open(iface)

    @staticmethod
    def _open(iface: str) -> socket.socket:
        if not sys.platform.startswith("linux") or not hasattr(socket, "AF_PACKET"):
            raise InterfaceError(f"--iface {iface}: live capture needs Linux (AF_PACKET)")
        try:
            sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, 0)  # no frames until bound
        except PermissionError as exc:
            raise InterfaceError(
                f"--iface {iface}: capturing needs root or CAP_NET_RAW ({exc.strerror})"
            ) from exc
        try:
            _attach_filter(sock, capture_filter())
            sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
            sock.setsockopt(SOL_PACKET, PACKET_AUXDATA, 1)
            try:  # root may pass net.core.rmem_max (as dumpcap's -B does), others get it
                sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, SOCKET_BUFFER_BYTES)
            except OSError:
                with contextlib.suppress(OSError):
                    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, SOCKET_BUFFER_BYTES)
            sock.bind((iface, ETH_P_ALL))
        except OSError as exc:
            sock.close()
            if exc.errno in (errno.ENODEV, errno.ENXIO):
                raise InterfaceError(f"--iface {iface}: no such network interface") from exc
            raise InterfaceError(f"--iface {iface}: cannot capture ({exc.strerror})") from exc
        sock.setblocking(False)
        return sock

    def stop(self) -> None:
        """End the capture (any thread): the frames the kernel stamped before this moment are
        still read, later ones are not."""
        self._stop_ns = time.time_ns()
        self._stop.set()

    def interrupt(self) -> None:
        """End the capture as Ctrl-C does (any thread): :meth:`stop`, and ``interrupted`` is
        True (the end line says ``(stopped by Ctrl-C)``)."""
        self.interrupted = True
        self.stop()

    @property
    def skipped(self) -> tuple[Skipped, ...]:
        """Nothing is skipped: every frame the kernel hands over is a record."""
        return ()

    @property
    def findings(self) -> tuple[FrameFinding, ...]:
        """``live.dropped`` when the kernel dropped frames we did not read in time."""
        if not self.dropped:
            return ()
        return (
            FrameFinding(
                -1,
                warning(
                    "live.dropped",
                    f"{self.dropped} frames dropped by the kernel on {self.iface} (read too "
                    "slowly); they are missing from the capture",
                ),
            ),
        )

    @property
    def total(self) -> int:
        """Frames captured."""
        return self.frames

    def __len__(self) -> int:
        return self.frames

    def __iter__(self) -> Iterator[Record]:
        if self._done:
            return
        self._done = True
        start = time.monotonic()
        end_ns = None if self.duration_s is None else time.time_ns() + round(self.duration_s * 1e9)
        try:
            with self.sigint_stops():
                while self.count is None or self.frames < self.count:
                    if self._stop.is_set():
                        end_ns = self._stop_ns if end_ns is None else min(end_ns, self._stop_ns)
                    if end_ns is not None and time.time_ns() >= end_ns:
                        yield from self._drain(end_ns)  # what arrived before the end
                        break
                    wait = (
                        POLL_S if end_ns is None else min(POLL_S, (end_ns - time.time_ns()) / 1e9)
                    )
                    ready, _, _ = select.select([self.sock], [], [], max(wait, 0.0))
                    if ready and not (yield from self._drain(end_ns)):
                        break
        finally:
            self.seconds = time.monotonic() - start
            self._close()

    def _drain(self, end_ns: int | None) -> Generator[Record, None, bool]:
        """The frames waiting in the socket, up to ``count`` and up to ``end_ns``; returns
        False when the capture is over (count reached, or a frame stamped after the end)."""
        while self.count is None or self.frames < self.count:
            rec = self._receive()
            if rec is None:
                return True
            if end_ns is not None and rec.time_ns > end_ns:
                return False
            self.frames += 1
            yield rec
        return False

    def _receive(self) -> Record | None:
        try:
            data, ancdata, _flags, _addr = self.sock.recvmsg(SNAPLEN, 256)
        except BlockingIOError:
            return None
        time_ns = None
        orig_len = len(data)
        for level, kind, value in ancdata:
            if level == socket.SOL_SOCKET and kind == SO_TIMESTAMPNS:
                sec, nsec = _TIMESPEC.unpack_from(value)
                time_ns = sec * 1_000_000_000 + nsec
            elif level == SOL_PACKET and kind == PACKET_AUXDATA:
                status, length, _snap, _mac, _net, tci, tpid = _AUXDATA.unpack_from(value)
                orig_len = length
                if status & TP_STATUS_VLAN_VALID:  # the kernel took the tag off: put it back
                    if not status & TP_STATUS_VLAN_TPID_VALID:
                        tpid = TPID_CTAG
                    data = data[:12] + struct.pack(">HH", tpid, tci) + data[12:]
                    orig_len += TAG_BYTES
        if time_ns is None:  # pragma: no cover - the kernel stamps every frame once asked
            time_ns = time.time_ns()
        return Record(
            index=self.frames,
            time_ns=time_ns,
            data=data,
            linktype=LINKTYPE_ETHERNET,
            orig_len=max(orig_len, len(data)),
            if_speed_bps=self._if_speed,
        )

    def _close(self) -> None:
        with contextlib.suppress(OSError):
            raw = self.sock.getsockopt(SOL_PACKET, PACKET_STATISTICS, _STATS.size)
            self.dropped += _STATS.unpack(raw)[1]
        self.sock.close()

    @contextlib.contextmanager
    def sigint_stops(self) -> Iterator[None]:
        """In the main thread, SIGINT (Ctrl-C) ends the capture instead of raising (reading
        does this itself; a caller that prints before reading wraps both in it, so that no
        Ctrl-C falls between). A second one goes to the handler before (Python's raises
        :class:`KeyboardInterrupt`): the caller may still be waiting, for a reader of its
        output that does not read, say."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        before = signal.getsignal(signal.SIGINT)

        def interrupted(signum: int, frame: FrameType | None) -> None:
            if not self.interrupted:
                self.interrupt()
            elif callable(before):
                before(signum, frame)
            elif before != signal.SIG_IGN:  # SIG_DFL, or a handler not set from Python
                raise KeyboardInterrupt

        previous = signal.signal(signal.SIGINT, interrupted)
        try:
            yield
        finally:
            signal.signal(signal.SIGINT, previous)
