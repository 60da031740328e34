"""Two chains in one process never see each other's state (issue "One ESC, written once"): fed
frames in turn, each returns exactly the frames and leaves exactly the memory it does alone.

The chains differ in what the ESCs share when configured alike (issue: process-wide caches of
decoded FMMU and SyncManager tables, plans and as-new SyncManager objects): different slave
counts, input sizes, mailboxes and clocks, hostile frames of two seeds aimed at their registers.
And no container at module level in ``emulator`` (nor at class level) grows while frames run:
what a chain decodes and plans is its own (``EcatChain.caches``).
"""

from __future__ import annotations

import collections
import itertools
import sys
from types import ModuleType

import numpy as np

from emulator.esc.chain import EcatChain, configure_frames
from emulator.hostile import hostile_frames, master_reset_frames
from skinframes import taxel

FRAME_NS = 200_000


def made(nodes: int, size: int, *, mailbox: bool) -> EcatChain:
    """A configured line on a clock of its own that moves ``FRAME_NS`` a frame."""
    chain = EcatChain.skin(nodes, size, mailbox=mailbox)
    ticks = itertools.count(0, FRAME_NS)
    chain.clock_ns = lambda: next(ticks)
    for frame in master_reset_frames(nodes) + configure_frames(chain.devices[0].info, nodes):
        chain.process_frame(frame)
    chain.publish(np.ascontiguousarray(taxel.sample_payloads(nodes, 1, size, seed=nodes)[0]))
    return chain


def frames_of(nodes: int, size: int, seed: int, count: int) -> list[bytes]:
    """Hostile frames with a master's reset and configuration now and then."""
    out: list[bytes] = []
    setup = master_reset_frames(nodes)
    for i, frame in enumerate(hostile_frames(count, nodes=nodes, input_bytes=size, seed=seed)):
        out.append(frame)
        if i % 150 == 149:
            out += setup
    return out


def run(chain: EcatChain, frames: list[bytes]) -> list[bytes | None]:
    return [chain.process_frame(f) for f in frames]


def test_two_chains_fed_in_turn_answer_as_each_does_alone() -> None:
    a_spec, b_spec = (8, 8, False), (5, 16, True)
    a_frames = frames_of(a_spec[0], a_spec[1], seed=21, count=900)
    b_frames = frames_of(b_spec[0], b_spec[1], seed=22, count=900)
    a_alone = made(a_spec[0], a_spec[1], mailbox=a_spec[2])
    a_back = run(a_alone, a_frames)
    b_alone = made(b_spec[0], b_spec[1], mailbox=b_spec[2])
    b_back = run(b_alone, b_frames)
    a = made(a_spec[0], a_spec[1], mailbox=a_spec[2])
    b = made(b_spec[0], b_spec[1], mailbox=b_spec[2])
    a_turns: list[bytes | None] = []
    b_turns: list[bytes | None] = []
    for fa, fb in itertools.zip_longest(a_frames, b_frames):
        if fa is not None:
            a_turns.append(a.process_frame(fa))
        if fb is not None:
            b_turns.append(b.process_frame(fb))
    assert sum(back is not None for back in a_back) > 500  # the frames did something
    for k, (alone, turns) in enumerate(zip(a_back, a_turns, strict=True)):
        assert alone == turns, f"chain A, frame {k}"
    for k, (alone, turns) in enumerate(zip(b_back, b_turns, strict=True)):
        assert alone == turns, f"chain B, frame {k}"
    assert np.array_equal(a.memory, a_alone.memory)
    assert np.array_equal(b.memory, b_alone.memory)


def containers(module: ModuleType) -> dict[str, int]:
    """The size of every container at ``module``'s level and at the level of its classes:
    dicts, lists, sets, deques, byte arrays, and functools caches (their entries)."""
    sizes: dict[str, int] = {}
    for name, value in list(vars(module).items()):
        places = [(name, value)]
        if isinstance(value, type) and value.__module__ == module.__name__:
            places += [(f"{name}.{attr}", v) for attr, v in vars(value).items()]
        for place, held in places:
            if isinstance(held, dict | list | set | bytearray | collections.deque):
                sizes[f"{module.__name__}.{place}"] = len(held)
            elif callable(getattr(held, "cache_info", None)):
                sizes[f"{module.__name__}.{place}"] = held.cache_info().currsize
    return sizes


def emulator_containers() -> dict[str, int]:
    every: dict[str, int] = {}
    for name, module in list(sys.modules.items()):
        if (name == "emulator" or name.startswith("emulator.")) and isinstance(module, ModuleType):
            every.update(containers(module))
    return every


def test_no_module_level_container_grows_while_frames_run() -> None:
    """Hostile frames (FMMU and SyncManager tables, logical accesses, EEPROM, AL control) and a
    master's set-up, through two chains of different configuration: every container at module
    or class level in ``emulator`` keeps its size (the caches are the chains' own)."""
    a, b = made(8, 8, mailbox=False), made(5, 16, mailbox=True)
    frames = {
        id(a): frames_of(8, 8, seed=23, count=600),
        id(b): frames_of(5, 16, seed=24, count=600),
    }
    before = emulator_containers()
    assert any(key.startswith("emulator.esc.") for key in before)  # the modules are looked at
    for chain in (a, b):
        run(chain, frames[id(chain)])
    grown = {
        k: (before.get(k, 0), n) for k, n in emulator_containers().items() if n > before.get(k, 0)
    }
    assert grown == {}
    assert len(a.caches.fmmu) > 1 and len(b.caches.sm) > 1  # the chains' own did fill
