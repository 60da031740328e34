"""Time units: the emulator counts integer picoseconds; reports convert to us or ns at the end.

One byte at 100 Mbit/s lasts exactly 80_000 ps, and the paper's 0.0005 us cable delay is 500 ps,
so every sum of the model is exact.
"""

from __future__ import annotations

from typing import Final

from emulator.errors import TopologyError

PS_PER_NS: Final = 1_000
PS_PER_US: Final = 1_000_000
PS_PER_S: Final = 1_000_000_000_000
BITS_PER_BYTE: Final = 8


def byte_time_ps(n_bytes: int, rate_bps: int) -> int:
    """Duration of ``n_bytes`` at ``rate_bps``, in ps (exact; raises if not a whole ps)."""
    num = n_bytes * BITS_PER_BYTE * PS_PER_S
    if num % rate_bps:
        raise TopologyError(f"{rate_bps} bit/s does not give a whole number of ps per byte")
    return num // rate_bps
