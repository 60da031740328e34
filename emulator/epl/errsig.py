"""Error signalling of a CN (EPSG DS 301 V1.4.0 6.5.5 and 6.5.8): EC/ER, EN/EA, error entries.

- **ER/EC** (6.5.5.1, the initialisation): the MN sets ER (exception reset) in the SoA
  StatusRequest to a CN; the CN answers a change of ER with EC (exception clear) equal to it and
  clears EN. A CN that has just been reset reports EC = 1 until the MN's ER goes 1 and back to
  0, which is how an MN learns that a CN was reset (openPOWERLINK's MN restarts the handshake
  when a ready CN reports EC = 1; its CN starts with EC = 1, ``dllkevent.c``).
- **EN/EA** (6.5.5.2): the CN toggles EN (exception new) in PRes and StatusResponse whenever a
  new entry joins its error list; the MN acknowledges with EA in the PReq and asks for the
  StatusResponse.
- **Entries** (6.5.8.2, Table 96): the StatusResponse's ErrorCodeList, the newest first, as many
  as its 72-byte frame holds (two); each entry says an EPL-profile error occurred
  (entry type ``EMCY | OCCURRED | PLK``, openPOWERLINK ``frame.h`` ERR_ENTRYTYPE_*) with its
  code (``errordefs.h``) and the time it happened.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Final

from skinframes.powerlink import ErrorEntry

ENTRY_EMERGENCY: Final = 0x4000  # bit 14: an emergency entry, signalled by EN
ENTRY_MODE_OCCURRED: Final = 0x3000  # bits 12-13: the error occurred (and is not pending)
ENTRY_PROFILE_EPL: Final = 0x0002  # bits 0-11: EPL communication profile error
ENTRY_TYPE: Final = ENTRY_EMERGENCY | ENTRY_MODE_OCCURRED | ENTRY_PROFILE_EPL  # 0x7002
E_DLL_LOSS_SOC_TH: Final = 0x8245  # loss of SoC threshold reached (errordefs.h, DS 301 Table 97)
ENTRIES_IN_STATUS_RESPONSE: Final = 2  # (72 - 14 - 4 - 14 fixed bytes) / 20 per entry
NS_PER_S: Final = 1_000_000_000


@dataclass
class ErrorSignalling:
    """One CN's EC, EN and error entries; ``changed`` says the frames carrying them are stale."""

    ec: bool = True  # reset state: EC set until the MN's ER handshake
    en: bool = False
    last_er: bool = False
    entries: deque[ErrorEntry] = field(
        default_factory=lambda: deque(maxlen=ENTRIES_IN_STATUS_RESPONSE)
    )

    def reset(self) -> None:
        """An NMT reset: EC set again, EN cleared (the entries stay: they are history)."""
        self.ec, self.en = True, False

    def status_request(self, er: bool) -> bool:
        """A StatusRequest with ER = ``er``: EC follows a change of ER (EN cleared); True if
        EC or EN changed. Cheap: called on the fast path before the answer is chosen."""
        if er == self.last_er:
            return False
        self.last_er = er
        changed = self.ec != er or self.en
        self.ec, self.en = er, False
        return changed

    def error(self, code: int, time_ns: int) -> None:
        """A new error: an entry at the head of the list, and EN toggled."""
        s, ns = divmod(time_ns, NS_PER_S)
        self.entries.appendleft(ErrorEntry(ENTRY_TYPE, code, s & 0xFFFFFFFF, ns))
        self.en = not self.en
