"""The skin's CAN frames as a DBC database (can.md 4), for CAN tools such as cantools."""

from __future__ import annotations

from collections.abc import Iterable

from skinframes.canbus.codec import (
    HEAD_MARKER,
    HEAD_TAXELS,
    MAX_CLASS,
    SKIN_CLASS,
    TAIL_MARKER,
    skin_id,
)
from skinframes.canbus.wire import check_range
from skinframes.errors import FieldRangeError
from skinframes.taxel import TAXELS_PER_TRIANGLE, TRIANGLES_PER_PATCH

_DBC_HEADER = """VERSION ""


NS_ :
\tCM_
\tBA_DEF_
\tBA_
\tVAL_

BS_:

"""


def dbc_text(
    boards: Iterable[int],
    skin_class: int = SKIN_CLASS,
    triangles: Iterable[int] = range(TRIANGLES_PER_PATCH),
) -> str:
    """A DBC database of the skin frames of ``boards``: one multiplexed message per triangle.

    Message ``SKIN_B<board>_T<triangle>`` (DLC 8, sender ``MTB<board>``), multiplexer ``PART``
    (byte 0; 64 head, 192 tail), ``P00..P06`` (m64, bytes 1-7), ``P07..P11`` (m192, bytes 1-5),
    ``OUTOFRANGE`` (m192, 12 bits from byte 6) and ``ERR`` (m192, low nibble of byte 7). All
    signals are big-endian (``@0``) with DBC's MSB start bits. cantools loads it; decoded values
    equal :class:`SkinFrame`'s.

    Raises:
        FieldRangeError: a board, triangle or class out of range; no boards.
    """
    board_list = sorted({int(b) for b in boards})
    tri_list = sorted({int(t) for t in triangles})
    if not board_list or not tri_list:
        raise FieldRangeError("dbc_text: need at least one board and one triangle")
    check_range("skin_class", skin_class, MAX_CLASS)
    nodes = " ".join(["HOST", *(f"MTB{b:02d}" for b in board_list)])
    lines = [_DBC_HEADER + f"BU_: {nodes}\n\n"]
    comments: list[str] = []
    values: list[str] = []
    sig = ' (1,0) [0|{high}] "" HOST'
    for b in board_list:
        for t in tri_list:
            ident = skin_id(b, t, skin_class)
            lines.append(f"BO_ {ident} SKIN_B{b:02d}_T{t:02d}: 8 MTB{b:02d}\n")
            lines.append(" SG_ PART M : 7|8@0+" + sig.format(high=255) + "\n")
            for k in range(TAXELS_PER_TRIANGLE):
                mux = HEAD_MARKER if k < HEAD_TAXELS else TAIL_MARKER
                byte = 1 + (k if k < HEAD_TAXELS else k - HEAD_TAXELS)
                lines.append(f" SG_ P{k:02d} m{mux} : {8 * byte + 7}|8@0+" + sig.format(high=255))
                lines.append("\n")
            lines.append(f" SG_ OUTOFRANGE m{TAIL_MARKER} : 55|12@0+" + sig.format(high=4095))
            lines.append(f"\n SG_ ERR m{TAIL_MARKER} : 59|4@0+" + sig.format(high=15) + "\n\n")
            comments.append(
                f'CM_ BO_ {ident} "iCub skin, class {skin_class}, board {b}, triangle {t}: '
                f'head PART=0x40 taxels 0-6, tail PART=0xC0 taxels 7-11 and status";\n'
            )
            values.append(f'VAL_ {ident} PART 64 "HEAD" 192 "TAIL" ;\n')
            values.append(f'VAL_ {ident} ERR 0 "OK" 1 "NOACK" 2 "NOT_CONNECTED" ;\n')
    return "".join(lines) + "\n" + "".join(comments) + "".join(values)
