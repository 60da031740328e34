"""The reference the chain's frame processing is held equal to: every ESC in turn runs every
datagram of the frame (:meth:`EcatChain._pass`), then ends the frame, as far as the ports let
the frame go. The chain's own path (:meth:`EcatChain._run_planned`) goes datagram by datagram
and over rows of ESCs at once; this is the ESC-by-ESC order it must give the same bytes as (the
product's only ESC-by-ESC path is :meth:`EcatChain.frame_effect`, for the timing engine)."""

from __future__ import annotations

from emulator.esc.chain import EcatChain
from skinframes import ethercat


class OneByOne(EcatChain):
    """A chain whose frames go ESC by ESC (the rest of :meth:`EcatChain._run` as the chain's)."""

    def _run_planned(
        self, buf: bytearray, layout: list[tuple[int, int, int, int, int, int]]
    ) -> bytes | None:
        mac_bit = False
        for dev in self.devices:
            self._pass(dev, buf, layout)
            mac_bit = mac_bit or dev.sets_mac
            onward = dev.onward  # loop changes wait for the end of the frame (II 2.4.1)
            dev.end_frame()
            if onward is None:
                self._drop(malformed=False)
                return None
            if not onward:
                break
        if mac_bit:
            buf[6] |= ethercat.RETURNED_MAC_BIT
        return bytes(buf)
