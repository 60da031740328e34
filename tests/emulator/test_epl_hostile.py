"""Hostile frames never stop the emulated EPL CNs: they are counted, and the CNs boot afterwards.

Random bytes behind the EPL EtherType, valid MN frames with random bytes flipped, and SDO
frames with random sequence numbers, sizes and commands go through the live loop's two steps
(:meth:`EplSkin.answer`, :meth:`EplSkin.after`); then the boot of DS 301 7.1.4 still works.
"""

from __future__ import annotations

import random

from epl_frames import feed, hostile, nmt_command, preq, soa, soc, status_of

from emulator.epl.skin import EplSkin

FRAMES = 20_000


def test_hostile_frames_are_counted_and_the_cns_still_boot() -> None:
    rng = random.Random(20261128)
    skin = EplSkin([1, 2], 24)
    for i in range(FRAMES):
        feed(skin, hostile(rng), now_ns=i * 1000)
    report = skin.report()
    counted = sum(report["counts"].values()) + sum(  # type: ignore[union-attr]
        sum(cn["counts"].values())
        for cn in report["cns"]  # type: ignore[union-attr, index]
    )
    assert counted > FRAMES // 10  # what was wrong is counted, not silently dropped
    # and afterwards an MN boots them as usual
    feed(skin, nmt_command(255, 0x28))  # NMTResetNode to all
    feed(skin, soa(0, 0))
    feed(skin, soc())
    for node in (1, 2):
        feed(skin, nmt_command(node, 0x24))
        feed(skin, nmt_command(node, 0x21))
        assert status_of(skin, node) == 0xFD
        pres = feed(skin, preq(node))
        assert pres is not None and pres[14 + 3] == 0xFD
