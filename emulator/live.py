"""The emulated chain on a live Linux network interface, for any EtherCAT master.

* :class:`RawSocket`: an AF_PACKET raw socket bound to one interface and EtherType 0x88A4 (what
  SOEM opens on the master side, ``nicdrv.c``); it needs root or CAP_NET_RAW.
* :func:`veth_netns`: a private network namespace holding a veth pair (master end, slave end),
  with unique names per run, always deleted again: on normal exit, on exceptions, on SIGINT and
  (in the main thread) on SIGTERM.
* :func:`netns_socket`: open a :class:`RawSocket` inside a named namespace from this thread.
* :class:`TaxelFeed` and :func:`serve`: answer every EtherCAT frame with the chain's processed
  frame and, between frames, let the patches publish new taxel samples (seeded contact
  patterns from :func:`skinframes.taxel.sample_payloads`), until a stop event is set; in a line
  that also holds slaves described by ESI files (:func:`mixed_chain`), those count their
  inputs one up at each publication (:class:`emulator.slave.esi_slave.EsiApplication`).

The recipe it automates, by hand::

    ip netns add ecat && ip -n ecat link add ecm0 type veth peer name ecs0
    ip -n ecat link set lo up && ip -n ecat link set ecm0 up && ip -n ecat link set ecs0 up
    ip netns exec ecat skinframes serve ecat --iface ecs0 --nodes 21 --bytes 192 &
    ip netns exec ecat <your master> ecm0
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import gc
import os
import secrets
import select
import signal
import socket
import struct
import subprocess
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from types import FrameType
from typing import Final, Protocol

import numpy as np
import numpy.typing as npt

from emulator.errors import LinkError
from emulator.esc.chain import EcatChain
from emulator.esc.device import EscDevice
from emulator.esc.registers import EscConfig
from emulator.slave.sii import SlaveInfo
from emulator.slave.state_machine import SkinPatchApplication
from skinframes import taxel
from skinframes.capture_writer import CAPTURE_SNAPLEN, CaptureWriter

__all__ = [
    "CPU_BUDGET_US",
    "ETH_P_ECAT",
    "ETH_P_EPL",
    "LinkError",
    "Publisher",
    "RawSocket",
    "ServeStats",
    "TaxelFeed",
    "VethPair",
    "mixed_chain",
    "netns_socket",
    "realtime",
    "serve",
    "veth_netns",
]

ETH_P_ECAT: Final = 0x88A4
ETH_P_EPL: Final = 0x88AB  # Ethernet POWERLINK (DS 301 4.6.1.1)
MAX_FRAME_BYTES: Final = 1522  # VLAN-tagged maximum without FCS
PACKET_OUTGOING: Final = 4  # linux/if_packet.h: a frame this host sent
SOL_PACKET: Final = 263  # linux/socket.h
PACKET_ADD_MEMBERSHIP: Final = 1  # linux/if_packet.h
PACKET_MR_PROMISC: Final = 1  # linux/if_packet.h, struct packet_mreq.mr_type
CLONE_NEWNET: Final = 0x40000000
SOCKET_BUFFER_BYTES: Final = 1 << 22


# --- raw socket ----------------------------------------------------------------------------------
class RawSocket:
    """An AF_PACKET socket for one EtherType (default 0x88A4) on one interface (no FCS).

    ``promiscuous`` asks the interface for every frame (PACKET_MR_PROMISC, packet(7)), as
    emulated nodes with MAC addresses of their own need (EPL: the MN sends each PReq to its
    CN's MAC address); the membership ends with the socket. A received frame keeps its first
    ``CAPTURE_SNAPLEN`` (65535) bytes, any Ethernet frame whole, jumbo frames too, and
    :meth:`receive` tells its length on the wire (``MSG_TRUNC``, packet(7)).

    Raises:
        LinkError: no such interface, or not root / no CAP_NET_RAW.
    """

    def __init__(
        self, iface: str, ethertype: int = ETH_P_ECAT, *, promiscuous: bool = False
    ) -> None:
        self.iface = iface
        try:
            sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ethertype))
        except PermissionError as exc:
            raise LinkError(
                f"opening a raw socket on {iface!r} needs root or CAP_NET_RAW ({exc.strerror})"
            ) from exc
        try:
            sock.bind((iface, ethertype))
        except OSError as exc:
            sock.close()
            if exc.errno in (errno.ENODEV, errno.ENXIO):
                raise LinkError(f"no network interface {iface!r}") from exc
            raise LinkError(f"cannot bind a raw socket to {iface!r}: {exc.strerror}") from exc
        for opt in (socket.SO_RCVBUF, socket.SO_SNDBUF):
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, opt, SOCKET_BUFFER_BYTES)
        if promiscuous:
            mreq = struct.pack("iHH8s", socket.if_nametoindex(iface), PACKET_MR_PROMISC, 0, b"")
            with contextlib.suppress(OSError):
                sock.setsockopt(SOL_PACKET, PACKET_ADD_MEMBERSHIP, mreq)
        sock.setblocking(False)
        self.sock = sock
        self._buffer = bytearray(CAPTURE_SNAPLEN)
        self._view = memoryview(self._buffer)

    def fileno(self) -> int:
        """The socket's file descriptor (for select)."""
        return self.sock.fileno()

    def receive(self) -> tuple[bytes, int] | None:
        """One received frame (its first 65535 bytes) and its length on the wire, None when
        nothing is waiting (frames this host sent skipped)."""
        while True:
            try:
                length, addr = self.sock.recvfrom_into(self._buffer, 0, socket.MSG_TRUNC)
            except BlockingIOError:
                return None
            if addr[2] != PACKET_OUTGOING:
                return bytes(self._view[:length]), length

    def recv(self) -> bytes | None:
        """One received frame (its first 65535 bytes), None when nothing is waiting."""
        got = self.receive()
        return None if got is None else got[0]

    def send(self, frame: bytes) -> None:
        """Transmit one frame."""
        self.sock.send(frame)

    def close(self) -> None:
        """Close the socket."""
        self.sock.close()

    def __enter__(self) -> RawSocket:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def realtime(priority: int) -> None:
    """Run this process under SCHED_FIFO at ``priority`` (sched(7)), as openPOWERLINK's demos do.

    Raises:
        LinkError: not permitted (root or CAP_SYS_NICE is needed) or no such priority.
    """
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (PermissionError, OSError) as exc:
        raise LinkError(f"SCHED_FIFO priority {priority}: {exc.strerror or exc}") from exc


# --- network namespaces ------------------------------------------------------------------------
def _ip(*args: str) -> str:
    try:
        done = subprocess.run(
            ["ip", *args], capture_output=True, text=True, timeout=30, check=False
        )
    except FileNotFoundError as exc:
        raise LinkError("the 'ip' command (iproute2) is not installed") from exc
    if done.returncode:
        msg = done.stderr.strip() or f"exit {done.returncode}"
        if "Operation not permitted" in msg or "Permission denied" in msg:
            raise LinkError(f"ip {' '.join(args)}: needs root or CAP_NET_ADMIN ({msg})")
        raise LinkError(f"ip {' '.join(args)}: {msg}")
    return done.stdout


@dataclass(frozen=True, slots=True)
class VethPair:
    """A private namespace and the two ends of its veth pair."""

    netns: str
    master: str
    slave: str


@contextlib.contextmanager
def _signals_as_exceptions() -> Iterator[None]:
    """In the main thread, turn a default SIGTERM into SystemExit so ``finally`` blocks run."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGTERM)
    if previous is not signal.SIG_DFL:
        yield
        return

    def terminate(signum: int, frame: FrameType | None) -> None:
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def _signals_blocked() -> Iterator[None]:
    """Hold SIGINT/SIGTERM back while cleaning up; they are delivered afterwards."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    blocked = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie waiting for its parent counts as ended)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as f:
            return f.read().rpartition(")")[2].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def _stop_namespace_processes(netns: str, grace_s: float = 2.0) -> None:
    """End what still runs inside our private namespace (started by us), then wait."""
    try:
        pids = [int(p) for p in _ip("netns", "pids", netns).split()]
    except LinkError:
        return
    pids = [p for p in pids if p != os.getpid()]
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for pid in pids:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)
        deadline = time.monotonic() + grace_s
        while pids and time.monotonic() < deadline:
            pids = [p for p in pids if _alive(p)]
            time.sleep(0.02)
        if not pids:
            return


@contextlib.contextmanager
def veth_netns(
    *, master: str = "ecm0", slave: str = "ecs0", prefix: str = "skinframes"
) -> Iterator[VethPair]:
    """A private network namespace with a veth pair, deleted on every way out.

    The namespace name is unique per run (``prefix-pid-random``); the veth pair is created
    inside it, so nothing appears in the caller's namespace. IPv6 is switched off inside so that
    captures hold only the EtherCAT traffic. On exit, processes still running in the namespace
    are terminated and the namespace (with its veth pair) is deleted.

    Raises:
        LinkError: ``ip`` is missing or not permitted (root or CAP_SYS_ADMIN is needed).
    """
    name = f"{prefix}-{os.getpid()}-{secrets.token_hex(3)}"
    with _signals_as_exceptions():
        _ip("netns", "add", name)
        try:
            _ip("-n", name, "link", "add", master, "type", "veth", "peer", "name", slave)
            for dev in ("lo", master, slave):
                _ip("-n", name, "link", "set", dev, "up")
            with contextlib.suppress(LinkError):
                _ip("netns", "exec", name, "sysctl", "-q", "-w", "net.ipv6.conf.all.disable_ipv6=1")
            yield VethPair(name, master, slave)
        finally:
            with _signals_blocked():
                _stop_namespace_processes(name)
                for _ in range(5):
                    try:
                        _ip("netns", "del", name)
                        break
                    except LinkError:
                        time.sleep(0.1)


@contextlib.contextmanager
def _in_netns(netns: str) -> Iterator[None]:
    """Switch this thread into ``netns`` (setns(2) acts on the calling thread only)."""
    libc = ctypes.CDLL(None, use_errno=True)
    own = os.open("/proc/thread-self/ns/net", os.O_RDONLY)
    try:
        try:
            target = os.open(f"/run/netns/{netns}", os.O_RDONLY)
        except FileNotFoundError as exc:
            raise LinkError(f"no network namespace {netns!r}") from exc
        try:
            if libc.setns(target, CLONE_NEWNET) != 0:
                err = ctypes.get_errno()
                raise LinkError(f"cannot enter network namespace {netns!r}: {os.strerror(err)}")
        finally:
            os.close(target)
        try:
            yield
        finally:
            if libc.setns(own, CLONE_NEWNET) != 0:  # pragma: no cover - would leave us inside
                raise LinkError("cannot return to the original network namespace")
    finally:
        os.close(own)


def netns_socket(iface: str, netns: str | None = None, ethertype: int = ETH_P_ECAT) -> RawSocket:
    """A :class:`RawSocket` on ``iface`` for ``ethertype``, created inside ``netns`` when given.

    A socket stays in the namespace it was created in, so the caller keeps working in its own.
    """
    if netns is None:
        return RawSocket(iface, ethertype)
    with _in_netns(netns):
        return RawSocket(iface, ethertype)


# --- serving -----------------------------------------------------------------------------------
class Publisher(Protocol):
    """What a :class:`TaxelFeed` publishes to besides an ESC line: the EPL skin."""

    def publish(self, payloads: npt.NDArray[np.uint8]) -> None:
        """One sample: row k of ``payloads`` (patches x bytes) to the k-th patch."""
        ...


class TaxelFeed:
    """Changing taxel patterns: sample ``k`` of ``taxel.sample_payloads(nodes, samples, B, seed)``.

    Every ``period_s`` the next sample (cycling through ``samples``) is published to all patches
    at once, between two frames. In a mixed line (:func:`mixed_chain`) the patches are the
    ESCs whose application is a skin patch's, in line order (``nodes`` of them, maybe 0), and
    every other application with a ``count(device)`` (an ESI slave's) counts one up.
    """

    def __init__(
        self,
        nodes: int,
        input_bytes: int,
        *,
        samples: int = 64,
        seed: int = 0,
        period_s: float = 0.001,
    ) -> None:
        self.payloads = (
            taxel.sample_payloads(nodes, samples, input_bytes, seed=seed)
            if nodes
            else np.zeros((samples, 0, 0), np.uint8)
        )
        self.period_s = period_s
        self.published = 0  # how many samples were published so far
        self._next = 0.0
        self._line: tuple[EcatChain, bool] | None = None  # (the chain, _patches_only)

    def sample_index(self, published: int | None = None) -> int:
        """Which sample the ``published``-th publication (default: the last one) used."""
        count = self.published if published is None else published
        return (count - 1) % len(self.payloads)

    def _patches_only(self, chain: EcatChain) -> bool:
        """Whether every slave of ``chain`` is a skin patch (asked once a chain: a line's
        applications stay those it was made with)."""
        if self._line is None or self._line[0] is not chain:
            self._line = (chain, all(type(d.app) is SkinPatchApplication for d in chain.devices))
        return self._line[1]

    def publish(self, chain: EcatChain | Publisher, now: float) -> bool:
        """Publish the next sample if the period has passed; True if it did.

        ``chain``: an ESC line (its patches and ESI slaves as above), or any other
        :class:`Publisher` (the EPL skin), which takes the sample's rows as they are.
        """
        if now < self._next:
            return False
        rows = self.payloads[self.published % len(self.payloads)]
        if not isinstance(chain, EcatChain):
            chain.publish(rows)  # the EPL skin: every row a patch's
        elif self._patches_only(chain):
            chain.publish(rows)
        else:
            _publish_line(chain.devices, rows)
        self.published += 1
        self._next = now + self.period_s
        return True


def _publish_line(devices: Sequence[EscDevice], rows: npt.NDArray[np.uint8]) -> None:
    """Each patch its row (in line order), each other slave its next count, between frames."""
    patch = 0
    for dev in devices:
        app = dev.app
        if isinstance(app, SkinPatchApplication):
            app.publish(dev, rows[patch].tobytes())
            patch += 1
        else:
            count = getattr(app, "count", None)
            if count is not None:
                count(dev)


def mixed_chain(
    nodes: int,
    input_bytes: int,
    others: Sequence[Callable[[], EscDevice]],
    *,
    mailbox: bool = True,
    config: EscConfig | None = None,
) -> EcatChain:
    """``nodes`` skin patches first (serial numbers 1..nodes, as :meth:`EcatChain.skin`), then
    one ESC from each of ``others`` (an ESI slave: :func:`emulator.slave.esi_slave.esi_device`),
    powered on and in INIT; a line of patches only is :meth:`EcatChain.skin`'s."""
    if not others:
        return EcatChain.skin(nodes, input_bytes, mailbox=mailbox, config=config)
    patches = [
        EscDevice(SlaveInfo.skin_patch(input_bytes, serial=i + 1, mailbox=mailbox), config=config)
        for i in range(nodes)
    ]
    return EcatChain([*patches, *(make() for make in others)])


@dataclass
class ServeStats:
    """What :func:`serve` did, with the processing time per frame in microseconds.

    ``errors`` counts the frames the chain could not process (an internal error: the frame is
    not answered, the ESCs finish it and serving goes on); ``error_messages`` keeps the first
    few (exception type and message). ``cpu_us_max`` is the largest CPU time one frame took
    (this thread's CPU clock) until its answer, ``over_budget`` the frames above
    ``CPU_BUDGET_US``; ``firmware_us_max`` the largest CPU time the slaves' applications then
    took to react to one frame (:meth:`EcatChain.run_firmware`, after the answer was sent).
    ``process_us`` keeps the first frames' wall time until their answer (answered frames),
    ``cpu_us`` their CPU time (every frame); the summary's percentiles are of those: the value at
    index ``int(q * count)`` of the sorted times.
    """

    frames_in: int = 0
    frames_out: int = 0
    dropped: int = 0
    publications: int = 0
    errors: int = 0
    error_messages: list[str] = field(default_factory=list)
    cpu_us_max: float = 0.0
    over_budget: int = 0
    firmware_us_max: float = 0.0
    process_us: list[float] = field(default_factory=list)
    cpu_us: list[float] = field(default_factory=list)

    def summary(self) -> dict[str, float | int]:
        """Counts and processing-time percentiles (us)."""
        times = sorted(self.process_us)
        cpu = sorted(self.cpu_us)

        def pct(q: float, values: list[float]) -> float:
            return round(values[min(len(values) - 1, int(q * len(values)))], 1) if values else 0.0

        return {
            "frames_in": self.frames_in,
            "frames_out": self.frames_out,
            "dropped": self.dropped,
            "errors": self.errors,
            "publications": self.publications,
            "process_us_median": pct(0.5, times),
            "process_us_p99": pct(0.99, times),
            "process_us_max": round(times[-1], 1) if times else 0.0,
            "cpu_us_median": pct(0.5, cpu),
            "cpu_us_p99": pct(0.99, cpu),
            "cpu_us_max": round(self.cpu_us_max, 1),
            "over_budget": self.over_budget,
            "firmware_us_max": round(self.firmware_us_max, 1),
        }


CPU_BUDGET_US: Final = 2000.0  # issue 11: at most 2 ms of CPU per frame at 160 slaves
MAX_ERROR_MESSAGES: Final = 10
YOUNG_OBJECTS: Final = 700  # new container objects that start a collection (CPython's default)
FULL_EVERY: Final = 100  # young collections between two full ones


class BetweenFrames:
    """Python's cyclic garbage collector, run between frames instead of inside one, over the
    objects made since it last ran only.

    CPython collects when enough new objects have been made, so a collection lands inside
    whichever frame makes the 700th; a full one, over everything made since :func:`gc.freeze`,
    took 5 ms at 160 slaves in ``bench_serve_hostile``, on one frame. Here automatic
    collection is off while serving: after a frame is answered (or dropped) the young
    generations are collected once ``YOUNG_OBJECTS`` accumulated, and every ``FULL_EVERY``-th
    time everything; what survives a collection is frozen (:func:`gc.freeze`: reference
    counting still frees it, no collection walks it again), so a collection walks the objects
    made since the last one, not what the chain's caches accumulated. Those had made full
    collections take up to 149 ms (236,200 objects after 16,000 frames of
    ``tests/hostile_any.py`` at 160 slaves, in process), and an answer come 22 ms late live;
    none of those collections found garbage (0 unreachable objects): an ESC's frames make no
    reference cycles that freezing could keep. EPL frames do (136,814 unreachable objects in
    the young collections over 40,000 hostile frames to 4 CNs, 465 more in a full one after
    them), and the EPL skin's objects are few: ``freeze=False`` keeps its collections as they
    were (the survivors not frozen). Use as a context manager (the collector's state is
    restored, its frozen objects unfrozen).
    """

    def __init__(self, *, freeze: bool = True) -> None:
        self._young = 0
        self._freeze = freeze
        self._was_enabled = gc.isenabled()

    def __enter__(self) -> BetweenFrames:
        self._was_enabled = gc.isenabled()
        gc.collect()
        gc.freeze()  # the chain's objects live as long as serve: no collection walks them
        gc.disable()
        return self

    def __exit__(self, *exc: object) -> None:
        gc.unfreeze()
        if self._was_enabled:
            gc.enable()

    def after_frame(self) -> None:
        """A frame is done: collect what it (and the ones before it) left, if enough, and freeze
        what survives."""
        if gc.get_count()[0] < YOUNG_OBJECTS:
            return
        self._young += 1
        if self._young >= FULL_EVERY:
            self._young = 0
            gc.collect()
        else:
            gc.collect(1)
        if self._freeze:
            gc.freeze()


def _abandon_frame(chain: EcatChain) -> None:
    """After an internal error: let every ESC finish the frame as far as it can."""
    for dev in chain.devices:
        with contextlib.suppress(Exception):
            dev.end_frame()
    with contextlib.suppress(Exception):
        chain.run_firmware()
    chain.firmware.clear()


def _count_cpu(stats: ServeStats, cpu_us: float, keep_times: int) -> None:
    """One frame's CPU until its answer (or its internal error): kept, the maximum, the budget."""
    if len(stats.cpu_us) < keep_times:
        stats.cpu_us.append(cpu_us)
    if cpu_us > stats.cpu_us_max:
        stats.cpu_us_max = cpu_us
    if cpu_us > CPU_BUDGET_US:
        stats.over_budget += 1


def _count_error(
    stats: ServeStats,
    exc: BaseException,
    frame: bytes,
    on_error: Callable[[BaseException, bytes], None] | None,
) -> None:
    """An internal error while serving ``frame``: counted, its first messages kept, reported."""
    stats.errors += 1
    if len(stats.error_messages) < MAX_ERROR_MESSAGES:
        stats.error_messages.append(f"{type(exc).__name__}: {exc}")
    if on_error is not None:
        on_error(exc, frame)


def serve(
    chain: EcatChain,
    sock: RawSocket,
    stop: threading.Event,
    *,
    feed: TaxelFeed | None = None,
    poll_s: float = 0.05,
    keep_times: int = 200_000,
    capture: CaptureWriter | None = None,
    on_error: Callable[[BaseException, bytes], None] | None = None,
) -> ServeStats:
    """Answer frames until ``stop`` is set; publish taxels from ``feed`` between frames.

    Each frame is answered as the ESCs return it (:meth:`EcatChain.answer`); then the slaves'
    firmware reacts to it (:meth:`EcatChain.run_firmware`: the ESM, the mailbox), before the next
    frame, as a slave's application sees the events its ESC raised once the frame has passed.

    Every frame the wire carries is legal input: one that still hits an internal error is
    counted (``errors``), handed to ``on_error`` with the frame, and not answered; serving
    goes on. ``capture`` records every received frame (inbound) and every answer (outbound)
    with the host's clock (``time.time_ns``) as it happens. The chain's distributed clocks run
    on ``time.monotonic_ns`` from here on. Garbage is collected between frames
    (:class:`BetweenFrames`).
    """
    stats = ServeStats()
    chain.clock_ns = time.monotonic_ns  # the ESCs' clocks (distributed clocks) run in host time
    with BetweenFrames() as collector:
        fd = sock.fileno()
        clock = time.perf_counter
        cpu = time.thread_time_ns
        wall_ns = time.time_ns
        while not stop.is_set():
            if feed is not None and feed.publish(chain, time.monotonic()):
                stats.publications += 1
            timeout = poll_s if feed is None else min(poll_s, feed.period_s)
            readable, _, _ = select.select([fd], [], [], timeout)
            if not readable:
                continue
            while (got := sock.receive()) is not None:
                frame, length = got
                stats.frames_in += 1
                if capture is not None:
                    capture.write(wall_ns(), frame, outbound=False, orig_len=length)
                t0, c0 = clock(), cpu()
                try:
                    back = chain.answer(frame)
                except Exception as exc:  # every frame is legal input: count it and go on
                    _count_cpu(stats, (cpu() - c0) / 1000.0, keep_times)
                    _abandon_frame(chain)
                    _count_error(stats, exc, frame, on_error)
                    continue
                cpu_us = (cpu() - c0) / 1000.0  # until the answer; counted once it is sent
                if back is None:
                    stats.dropped += 1
                else:
                    sock.send(back)
                    if len(stats.process_us) < keep_times:
                        stats.process_us.append((clock() - t0) * 1e6)
                    if capture is not None:
                        capture.write(wall_ns(), back, outbound=True)
                    stats.frames_out += 1
                _count_cpu(stats, cpu_us, keep_times)
                if chain.firmware:  # the slaves' firmware reacts once the frame has passed
                    c0 = cpu()
                    try:
                        chain.run_firmware()
                    except Exception as exc:
                        chain.firmware.clear()
                        _count_error(stats, exc, frame, on_error)
                    stats.firmware_us_max = max(stats.firmware_us_max, (cpu() - c0) / 1000.0)
                collector.after_frame()
    return stats
