"""The emulated MN's cycle on a link: when frames go out and how long it waits for answers.

:func:`run_mn` drives an :class:`~emulator.epl.mn.EplMn` over a :class:`Link` (a raw socket,
:class:`SocketLink`, or anything that sends and receives frames):

1. NMTResetNode to every node, then a pause while the CNs reset (``RESET_WAIT_NS``);
2. the reduced cycle (the MN in PreOperational1): SoA only, each followed by its asynchronous
   slot, until every CN is identified (at most ``REDUCED_MAX_NS``);
3. the isochronous cycle every 0x1006 us: SoC; per polled CN a PReq, then up to its PRes
   timeout (0x1F92) for its PRes (timed from the PReq's send to the PRes's receipt, on this
   host's clock: what a capture here shows); SoA and the asynchronous slot (up to 0x1F8A/2 for
   an invited CN's ASnd); then the frames that come until the next SoC.

It runs until ``stop`` is set or, with ``cycles``, until that many cycles have passed with every
CN Operational. A frame that still hits an internal error is counted (``errors``, the first
messages kept) and the MN goes on.
"""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Final, Protocol

from emulator.epl.mn import EplMn
from emulator.live import MAX_ERROR_MESSAGES, RawSocket
from skinframes.capture_writer import CaptureWriter
from skinframes.powerlink import ASnd, EplMessage, PRes

NS_PER_S: Final = 1_000_000_000
RESET_WAIT_NS: Final = 1_000_000_000  # openPOWERLINK's CN takes ~0.5 s to reset (kit README)
REDUCED_MAX_NS: Final = 5_000_000_000  # the reduced cycle ends then even if a CN is missing
REDUCED_PAUSE_NS: Final = 1_000_000  # between two SoAs of the reduced cycle


class Link(Protocol):
    """Where the MN's frames go and come from; times in ns of one monotonic clock."""

    def now_ns(self) -> int:
        """The clock."""
        ...

    def send(self, frame: bytes) -> int:
        """Send ``frame``; when it went."""
        ...

    def recv(self, until_ns: int) -> tuple[bytes, int] | None:
        """The next received frame and when it came, or None once ``until_ns`` passed."""
        ...


class SocketLink:
    """A :class:`Link` on a raw socket, recording every frame in ``capture`` (host clock).

    A sent frame is recorded only when the link next waits or receives (with the time it was
    sent): between a PReq and its PRes the MN does no more than send and wait.
    """

    def __init__(self, sock: RawSocket, capture: CaptureWriter | None = None) -> None:
        self.sock = sock
        self.capture = capture
        self.frames_in = self.frames_out = 0
        self._fd = sock.fileno()
        self._sent: list[tuple[int, bytes]] = []  # sent, not yet recorded
        self._wall_offset_ns = time.time_ns() - time.monotonic_ns()

    def now_ns(self) -> int:
        return time.monotonic_ns()

    def wall_ns(self, mono_ns: int) -> int:
        """The wall clock time of a monotonic one."""
        return mono_ns + self._wall_offset_ns

    def send(self, frame: bytes) -> int:
        self.sock.send(frame)
        sent = time.monotonic_ns()
        self.frames_out += 1
        if self.capture is not None:
            self._sent.append((sent, frame))
        return sent

    def record_sent(self) -> None:
        """Record the frames sent since the last wait (the capture is complete after it)."""
        if self.capture is not None:
            for sent, frame in self._sent:
                self.capture.write(self.wall_ns(sent), frame, outbound=True)
        self._sent.clear()

    def recv(self, until_ns: int) -> tuple[bytes, int] | None:
        while True:
            got = self.sock.receive()
            now = time.monotonic_ns()
            if got is not None:
                frame, length = got
                self.frames_in += 1
                self.record_sent()
                if self.capture is not None:
                    self.capture.write(self.wall_ns(now), frame, outbound=False, orig_len=length)
                return frame, now
            self.record_sent()
            if now >= until_ns:
                return None
            select.select([self._fd], [], [], (until_ns - now) / NS_PER_S)


@dataclass
class MnRunStats:
    """What :func:`run_mn` did."""

    started_ns: int = 0
    net_time_offset_ns: int = 0  # wall clock - the link's clock, for the SoC's NetTime
    cycles: int = 0
    operational_cycles: int = 0
    all_operational_ns: int | None = None
    overruns: int = 0  # cycles that ended after the next SoC was due
    errors: int = 0
    error_messages: list[str] = field(default_factory=list)


@dataclass
class _Runner:
    mn: EplMn
    link: Link
    stop: threading.Event
    on_error: Callable[[BaseException, bytes], None] | None
    stats: MnRunStats

    def take(self, data: bytes, when_ns: int) -> EplMessage | None:
        """Hand a received frame to the MN; an internal error is counted, never raised."""
        try:
            return self.mn.receive(data, when_ns)
        except Exception as exc:  # every frame is legal input: count it, go on
            self.stats.errors += 1
            if len(self.stats.error_messages) < MAX_ERROR_MESSAGES:
                self.stats.error_messages.append(f"{type(exc).__name__}: {exc}")
            if self.on_error is not None:
                self.on_error(exc, data)
            return None

    def _late(self, message: EplMessage | None) -> None:
        if isinstance(message, PRes) and message.src in self.mn.by_id:
            self.mn.pres_late(self.mn.by_id[message.src])

    def drain(self, until_ns: int) -> None:
        """Take what comes until ``until_ns`` (or ``stop``)."""
        while not self.stop.is_set() and (got := self.link.recv(until_ns)) is not None:
            self._late(self.take(*got))

    def async_slot(self) -> None:
        """SoA, then the MN's ASnd or up to the slot timeout for the invited CN's."""
        soa, asnd, invited = self.mn.async_slot()
        sent = self.link.send(soa)
        if asnd is not None:
            self.link.send(asnd)
        if invited is None:
            return
        until = sent + self.mn.config.async_slot_ns
        while (got := self.link.recv(until)) is not None:
            message = self.take(*got)
            if isinstance(message, ASnd) and message.src == invited:
                return
            self._late(message)

    def poll(self) -> None:
        """A PReq to each polled CN, each waiting up to its PRes timeout for the PRes."""
        mn, link = self.mn, self.link
        for node in mn.polled():
            sent = link.send(mn.preq(node))
            until = sent + node.config.pres_timeout_ns
            while (got := link.recv(until)) is not None:
                message = self.take(*got)
                if isinstance(message, PRes) and message.src == node.node_id:
                    mn.pres_answered(node, got[1] - sent)
                    break
                self._late(message)
            else:
                mn.pres_missing(node)


def run_mn(
    mn: EplMn,
    link: Link,
    stop: threading.Event,
    *,
    cycles: int | None = None,
    net_time_offset_ns: int = 0,
    on_error: Callable[[BaseException, bytes], None] | None = None,
) -> MnRunStats:
    """Boot and cycle the CNs of ``mn`` on ``link`` until ``stop`` (or ``cycles`` cycles with
    every CN Operational). ``net_time_offset_ns`` turns the link's clock into the NetTime the
    SoCs carry (the wall clock, for a live link)."""
    stats = MnRunStats(started_ns=link.now_ns(), net_time_offset_ns=net_time_offset_ns)
    run = _Runner(mn, link, stop, on_error, stats)
    for frame in mn.reset_all():
        link.send(frame)
    run.drain(stats.started_ns + RESET_WAIT_NS)
    reduced_until = link.now_ns() + REDUCED_MAX_NS
    while not stop.is_set() and link.now_ns() < reduced_until and mn.unidentified():
        run.async_slot()
        run.drain(link.now_ns() + REDUCED_PAUSE_NS)
    mn.isochronous = True
    cycle_ns = mn.config.cycle_us * 1000
    next_soc = link.now_ns()
    while not stop.is_set():
        relative_us = (next_soc - stats.started_ns) // 1000
        link.send(mn.soc(next_soc + net_time_offset_ns, relative_us))
        run.poll()
        run.async_slot()
        mn.cycles = stats.cycles = stats.cycles + 1
        if mn.operational():
            if stats.all_operational_ns is None:
                stats.all_operational_ns = link.now_ns()
            stats.operational_cycles += 1
            if cycles is not None and stats.operational_cycles >= cycles:
                break
        next_soc += cycle_ns
        now = link.now_ns()
        if now > next_soc:
            stats.overruns += 1
            next_soc = now
        run.drain(next_soc)
    return stats
