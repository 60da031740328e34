"""The emulated chain under frames of a generator that is not its own (tests/hostile_any.py).

Every frame from the wire is legal input to an ESC (ETG.1000.4: a slave processes or forwards
what it receives, it cannot refuse it): no exception may escape the chain, an answer is the
frame sent, returned at its length (ESCs process frames on the fly, they neither add nor remove
bytes), and afterwards a master that resets and configures the line reads every patch's inputs.
"""

from __future__ import annotations

import itertools
import traceback

import hostile_any
import pytest

from emulator.esc import mapping
from emulator.esc.chain import EcatChain, configure_frames
from emulator.hostile import master_reset_frames
from emulator.slave.sii import SlaveInfo
from skinframes import ethercat, taxel
from skinframes.ethercat import Command, Datagram, EcatFrame

SIZE_BYTES = 8  # taxel bytes per patch, as bench_serve_hostile and bench_hostile_any
FRAME_NS = 250_000  # the ESCs' clocks advance this much per frame (serve: host time)
RESET_EVERY = 500  # hostile frames between a master's reset and configuration


def forget_shared_caches() -> None:
    """Empty what ESCs share between chains (:func:`emulator.esc.mapping.forget`), so that a
    case does not depend on the tests run before it."""
    forget = getattr(mapping, "forget", None)
    if callable(forget):
        forget()


def master_frames(nodes: int) -> list[bytes]:
    """A master's reset, then its configuration of serve's patches (CoE mailbox, inputs)."""
    info = SlaveInfo.skin_patch(SIZE_BYTES, mailbox=True)
    return master_reset_frames(nodes) + configure_frames(info, nodes)


def serve_chain(nodes: int) -> EcatChain:
    """The patches ``serve ecat`` builds, configured to OP, on a clock that advances by
    ``FRAME_NS`` each time it is read (deterministic, unlike serve's host time)."""
    chain = EcatChain.skin(nodes, SIZE_BYTES, mailbox=True)
    ticks = itertools.count(0, FRAME_NS)
    chain.clock_ns = lambda: next(ticks)
    for frame in master_frames(nodes):
        chain.process_frame(frame)
    return chain


def escaping(chain: EcatChain, frames: list[bytes], nodes: int) -> list[str]:
    """Feed ``frames`` with a master's reset and configuration every ``RESET_EVERY``; what went
    wrong: exceptions that escaped ``process_frame`` and answers of another length."""
    found: list[str] = []
    master = master_frames(nodes)
    for i, frame in enumerate(frames):
        try:
            back = chain.process_frame(frame)
        except Exception as exc:
            where = traceback.extract_tb(exc.__traceback__)[-1]
            found.append(
                f"frame {i}: {type(exc).__name__}: {exc} at {where.filename}:{where.lineno} "
                f"({hostile_any.describe(frame)})"
            )
            continue
        if back is not None and len(back) != len(frame):
            found.append(f"frame {i}: {len(frame)} bytes sent, {len(back)} back")
        if i % RESET_EVERY == RESET_EVERY - 1:
            for m in master:
                chain.process_frame(m)
    return found


def lrd_reads_inputs(chain: EcatChain, nodes: int) -> None:
    """A master resets and configures the line; an LRD of the image returns every patch's
    published inputs, read once by each (ETG.1000.4 Table 14: LRD, WKC + 1 per slave read)."""
    for frame in master_frames(nodes):
        chain.process_frame(frame)
    rows = taxel.sample_payloads(nodes, 1, SIZE_BYTES, seed=5)[0]
    chain.publish(rows)
    lrd = Datagram.logical(Command.LRD, 0, bytes(nodes * SIZE_BYTES))
    back = chain.process_frame(ethercat.frame(EcatFrame((lrd,))).to_bytes())
    assert back is not None, "the LRD of the image was not answered"
    (d,) = ethercat.decode(back[14:])[0].datagrams
    assert (d.wkc, d.data) == (nodes, rows.tobytes())


def test_the_generator_is_seeded_and_bounded() -> None:
    a = list(hostile_any.frames(500, nodes=8, seed=3))
    assert a == list(hostile_any.frames(500, nodes=8, seed=3))
    assert a != list(hostile_any.frames(500, nodes=8, seed=4))
    assert max(map(len, a)) <= hostile_any.MAX_FRAME_BYTES
    commands = {cmd for f in a for cmd, *_ in hostile_any.datagrams(f)}
    assert set(range(16)) <= commands


@pytest.mark.parametrize(
    ("nodes", "count", "seed"),
    [  # seed 1 at 8 and 160 raised ValueError in EscDevice._own before commit 29d6fd2's line
        (8, 10_000, 1),
        (8, 10_000, 2),
        (40, 5_000, 2),
        (160, 3_000, 1),
        (160, 3_000, 3),
    ],
)
def test_no_exception_escapes_and_a_master_recovers(nodes: int, count: int, seed: int) -> None:
    forget_shared_caches()
    chain = serve_chain(nodes)
    frames = list(hostile_any.frames(count, nodes=nodes, seed=seed))
    found = escaping(chain, frames, nodes)
    assert not found, f"{len(found)} of {count} frames (seed {seed}):\n" + "\n".join(found[:10])
    lrd_reads_inputs(chain, nodes)
