"""What the emulated MN's offline tests share: the kit's shipped CDC, and links that put the
emulated CNs (emulator.epl.skin) at the other end of the MN's wire.

The emulated CNs are the MN's counterpart offline only; the judge is the real openPOWERLINK CN
(tests/emulator/test_live_epl_mn.py).
"""

from __future__ import annotations

import lzma
import os
import socket
import tarfile
from collections import deque
from collections.abc import Callable
from pathlib import Path

import pytest

from emulator.epl.skin import EplSkin

ROOT = Path(__file__).resolve().parents[1]
KIT = Path(os.environ.get("OPENPOWERLINK_KIT", ROOT.parent / "shared" / "tools" / "openpowerlink"))
ARCHIVE = KIT / "openpowerlink-src.tar.xz"
DEMO = "apps/common/openCONFIGURATOR_projects/Demo_3CN/output/"
IN_CI = os.environ.get("CI", "").lower() == "true"
WIRE_NS = 30_000  # PReq -> PRes (or SoA -> ASnd) on the simulated wire


def shipped_files() -> dict[str, bytes]:
    """``mnobd.cdc`` and ``mnobd.txt`` from the kit's archive (openCONFIGURATOR's Demo_3CN),
    or skip (fail under CI=true)."""
    if not ARCHIVE.is_file():
        reason = f"no openPOWERLINK kit archive at {ARCHIVE} (set OPENPOWERLINK_KIT)"
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    found: dict[str, bytes] = {}
    with lzma.open(ARCHIVE) as xz, tarfile.open(fileobj=xz) as tar:
        for member in tar:
            for name in ("mnobd.cdc", "mnobd.txt"):
                if member.name.endswith(DEMO + name):
                    f = tar.extractfile(member)
                    assert f is not None
                    found[name] = f.read()
    assert set(found) == {"mnobd.cdc", "mnobd.txt"}
    return found


def skin_answer(skin: EplSkin, frame: bytes, now_ns: int) -> bytes | None:
    """What the emulated CNs send back to ``frame`` (after which they react to it)."""
    answer = skin.answer(frame)
    skin.after(frame, answer, now_ns)
    return answer


class SimLink:
    """A Link (emulator.epl.mn_live) to the emulated CNs on a simulated clock: each frame takes
    1 us to send, an answer comes WIRE_NS after its request; ``drop`` decides which answers
    are lost, ``inject`` adds frames of its own after each sent frame."""

    def __init__(
        self,
        skin: EplSkin,
        *,
        drop: Callable[[bytes], bool] = lambda frame: False,
        inject: Callable[[bytes], list[bytes]] = lambda frame: [],
    ) -> None:
        self.skin, self.drop, self.inject = skin, drop, inject
        self.t = 0
        self.queue: deque[tuple[int, bytes]] = deque()
        self.sent: list[bytes] = []

    def now_ns(self) -> int:
        return self.t

    def send(self, frame: bytes) -> int:
        self.t += 1_000
        self.sent.append(frame)
        answer = skin_answer(self.skin, frame, self.t)
        if answer is not None and not self.drop(answer):
            self.queue.append((self.t + WIRE_NS, answer))
        self.queue.extend((self.t + WIRE_NS, f) for f in self.inject(frame))
        return self.t

    def recv(self, until_ns: int) -> tuple[bytes, int] | None:
        if self.queue and self.queue[0][0] <= until_ns:
            when, frame = self.queue.popleft()
            self.t = max(self.t, when)
            return frame, self.t
        self.t = max(self.t, until_ns)
        self.skin.tick(self.t)
        return None


class SkinSocket:
    """Stands in for emulator.live.RawSocket: the emulated CNs answer each sent frame at once
    (a socket pair only gives select a descriptor)."""

    def __init__(self, skin: EplSkin) -> None:
        self.skin = skin
        self.inbox: deque[bytes] = deque()
        self.outbox: list[bytes] = []
        self.r, self.w = socket.socketpair()

    def fileno(self) -> int:
        return self.r.fileno()

    def send(self, frame: bytes) -> None:
        self.outbox.append(frame)
        answer = skin_answer(self.skin, frame, len(self.outbox))
        if answer is not None:
            self.inbox.append(answer)

    def receive(self) -> tuple[bytes, int] | None:
        if not self.inbox:
            return None
        frame = self.inbox.popleft()
        return frame, len(frame)

    def __enter__(self) -> SkinSocket:
        return self

    def __exit__(self, *exc: object) -> None:
        self.r.close()
        self.w.close()
