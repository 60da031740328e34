"""The EPL skin on a live interface: answer PReq and SoA at once, react between frames.

:func:`serve_epl` reads EPL frames (EtherType 0x88AB) from a :class:`~emulator.live.RawSocket`
and, for each, first sends what :meth:`EplSkin.answer` prepared (the PRes to a PReq: the MN
waits for it no longer than its PRes timeout 0x1F92, 200 us in openPOWERLINK's shipped CDC), and
only then lets the nodes react (:meth:`EplSkin.after`: NMT, SDO, PDO data), runs their timers
and publishes taxel samples. The garbage collector runs between frames (:class:`BetweenFrames`),
as in ``serve ecat``.
"""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Final

from emulator.epl.skin import EplSkin
from emulator.live import MAX_ERROR_MESSAGES, BetweenFrames, RawSocket, TaxelFeed
from skinframes.capture_writer import CaptureWriter

TICK_S: Final = 0.005  # the nodes' timers (loss of SoC) run at least this often
# Nodes given the last taxel sample after each frame (EplSkin.refresh): eight of 192 bytes took
# 26 us on the 2-core development machine (timeit), so a PReq waits at most that long for this
# work, and an MN's frames (one PReq per node and cycle at least) hand a sample to every node
# within one cycle.
REFRESH_NODES: Final = 8


@dataclass
class EplServeStats:
    """What :func:`serve_epl` did; ``answer_us`` the first answers' time from receipt to send."""

    frames_in: int = 0
    frames_out: int = 0
    publications: int = 0
    errors: int = 0
    error_messages: list[str] = field(default_factory=list)
    answer_us: list[float] = field(default_factory=list)
    answer_us_max: float = 0.0

    def summary(self) -> dict[str, float | int]:
        """Counts and answer-time percentiles (us): the value at index ``int(q * count)``."""
        times = sorted(self.answer_us)

        def pct(q: float) -> float:
            return round(times[min(len(times) - 1, int(q * len(times)))], 1) if times else 0.0

        return {
            "frames_in": self.frames_in,
            "frames_out": self.frames_out,
            "errors": self.errors,
            "publications": self.publications,
            "answer_us_median": pct(0.5),
            "answer_us_p99": pct(0.99),
            "answer_us_max": round(self.answer_us_max, 1),
        }


def serve_epl(
    skin: EplSkin,
    sock: RawSocket,
    stop: threading.Event,
    *,
    feed: TaxelFeed | None = None,
    capture: CaptureWriter | None = None,
    keep_times: int = 200_000,
    on_error: Callable[[BaseException, bytes], None] | None = None,
) -> EplServeStats:
    """Serve the skin's CNs on ``sock`` until ``stop`` is set.

    Every frame the wire carries is legal input: one that still hits an internal error is
    counted (``errors``, the first messages kept), handed to ``on_error``, and serving goes on.
    ``capture`` records every received and sent frame with the host's clock.
    """
    stats = EplServeStats()
    fd = sock.fileno()
    clock_ns = time.monotonic_ns
    wall_ns = time.time_ns
    perf = time.perf_counter
    answer = skin.answer
    send = sock.send
    receive = sock.receive
    next_tick = 0
    with BetweenFrames(freeze=False) as collector:  # EPL frames make reference cycles
        while not stop.is_set():
            if feed is not None and feed.publish(skin, time.monotonic()):
                stats.publications += 1
            timeout = TICK_S if feed is None else min(TICK_S, feed.period_s)
            readable, _, _ = select.select([fd], [], [], timeout)
            if not readable:  # a quiet moment: every node gets the last sample
                skin.refresh()
            else:
                while (got := receive()) is not None:
                    frame, length = got
                    t0, seen_ns = perf(), wall_ns()
                    back = answer(frame)  # the fast path: a prepared frame, or None
                    if back is not None:
                        send(back)
                        sent_ns = wall_ns()
                        took_us = (perf() - t0) * 1e6
                        stats.frames_out += 1
                        if len(stats.answer_us) < keep_times:
                            stats.answer_us.append(took_us)
                        stats.answer_us_max = max(stats.answer_us_max, took_us)
                    stats.frames_in += 1
                    if capture is not None:
                        capture.write(seen_ns, frame, outbound=False, orig_len=length)
                        if back is not None:
                            capture.write(sent_ns, back, outbound=True)
                    try:
                        skin.after(frame, back, clock_ns())
                    except Exception as exc:  # every frame is legal input: count it, go on
                        stats.errors += 1
                        if len(stats.error_messages) < MAX_ERROR_MESSAGES:
                            stats.error_messages.append(f"{type(exc).__name__}: {exc}")
                        if on_error is not None:
                            on_error(exc, frame)
                    collector.after_frame()
                    skin.refresh(REFRESH_NODES)
            now = clock_ns()
            if now >= next_tick:
                skin.tick(now)
                next_tick = now + int(TICK_S * 1e9)
    return stats
