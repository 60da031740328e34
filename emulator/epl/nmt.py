"""The NMT state machine of a Controlled Node (EPSG DS 301 V1.4.0 7.1.3 and 7.1.4).

One method per event; every transition names its clause (NMT_GTx generic, NMT_CTx CN-specific).
The reset states (Initialising, ResetApplication, ResetCommunication, ResetConfiguration) are
passed through at once: the machine rests in one of the CN states NotActive, PreOperational1,
PreOperational2, ReadyToOperate, Operational, Stopped, BasicEthernet. What a reset does to the
object dictionary is the caller's (``on_reset``): the state machine only says which one ran.

openPOWERLINK's ``nmtk.c`` (``doStateCs*``) implements the same table; where DS 301 leaves a
choice this follows it (a StartNode in Stopped is ignored; an unknown command is ignored).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Final

from skinframes.powerlink import NmtCommandId, NmtState


class Reset(Enum):
    """Which reset ran (DS 301 7.1.3.2): each includes the ones after it."""

    APPLICATION = "application"  # NMTResetNode, NMTSwReset, power on
    COMMUNICATION = "communication"  # NMTResetCommunication
    CONFIGURATION = "configuration"  # NMTResetConfiguration


# DS 301 7.3.1.2.2: the extended (node-list) commands are the plain ones + 0x20, with a 32-byte
# NMT node list in the data (bit n of byte n // 8 = node n).
EXTENDED_OFFSET: Final = 0x20
NODE_LIST_BYTES: Final = 32

# The CN states in which the DLL runs the isochronous phase (loss of SoC/PReq counts there)
CYCLIC_STATES: Final = frozenset(
    {
        NmtState.PRE_OPERATIONAL_2,
        NmtState.READY_TO_OPERATE,
        NmtState.OPERATIONAL,
        NmtState.STOPPED,
    }
)


def addressed(command_id: int, data: bytes, node_id: int) -> tuple[int, bool]:
    """The plain command of an NMTCommand and whether it addresses ``node_id``.

    A plain command addresses whoever the ASnd went to (the caller checked the destination);
    an extended one (0x41-0x4B, DS 301 7.3.1.2.2) the nodes whose bit is set in its node list
    (bytes missing at its end are zeros: the Ethernet padding of a minimum-size frame).
    """
    plain = command_id - EXTENDED_OFFSET
    if NmtCommandId.START_NODE <= plain <= NmtCommandId.SW_RESET:
        byte = node_id // 8
        return plain, byte < min(len(data), NODE_LIST_BYTES) and bool(
            data[byte] >> (node_id % 8) & 1
        )
    return command_id, True


@dataclass
class CnStateMachine:
    """NMT CN states; ``on_reset`` is called with each reset that runs (power on included).

    Attributes:
        state: the present state (an :class:`NmtState`).
        changes: how many state changes happened.
    """

    on_reset: Callable[[Reset], None] = lambda reset: None
    state: NmtState = NmtState.GS_OFF
    changes: int = 0
    history: list[tuple[NmtState, NmtState]] = field(default_factory=list)
    keep_history: int = 64

    def _go(self, new: NmtState) -> None:
        if new != self.state:
            if len(self.history) >= self.keep_history:
                del self.history[0]
            self.history.append((self.state, new))
            self.state = new
            self.changes += 1

    def power_on(self) -> None:
        """NMT_GT1, GT10: Initialising, then every reset down to NotActive."""
        self._go(NmtState.GS_INITIALISING)
        self._reset(Reset.APPLICATION)

    def _reset(self, reset: Reset) -> None:
        """NMT_GT2/GT4-GT8 and NMT_CT1: through the reset states into NotActive."""
        if reset is Reset.APPLICATION:
            self._go(NmtState.GS_RESET_APPLICATION)
        if reset in (Reset.APPLICATION, Reset.COMMUNICATION):
            self._go(NmtState.GS_RESET_COMMUNICATION)
        self._go(NmtState.GS_RESET_CONFIGURATION)
        self.on_reset(reset)
        self._go(NmtState.NOT_ACTIVE)

    # --- events ------------------------------------------------------------------------------
    def soc_or_soa(self, *, soc: bool) -> None:
        """A SoC or SoA was received.

        NMT_CT2: NotActive -> PreOp1 on SoA or SoC; NMT_CT4: PreOp1 -> PreOp2 on SoC;
        NMT_CT12: BasicEthernet -> PreOp1 on any EPL frame.
        """
        if self.state in (NmtState.NOT_ACTIVE, NmtState.BASIC_ETHERNET):
            self._go(NmtState.PRE_OPERATIONAL_1)
        if soc and self.state == NmtState.PRE_OPERATIONAL_1:
            self._go(NmtState.PRE_OPERATIONAL_2)

    def pdo_frame(self) -> None:
        """A PReq or PRes was received: NMT_CT12 BasicEthernet -> PreOp1."""
        if self.state == NmtState.BASIC_ETHERNET:
            self._go(NmtState.PRE_OPERATIONAL_1)

    def basic_ethernet_timeout(self) -> None:
        """NMT_CT3: no EPL frame in NotActive for 0x1F99 -> BasicEthernet."""
        if self.state == NmtState.NOT_ACTIVE:
            self._go(NmtState.BASIC_ETHERNET)

    def cycle_error(self) -> None:
        """NMT_CT11: a DLL error (loss of SoC past its threshold) in PreOp2, ReadyToOperate,
        Operational or Stopped -> PreOp1."""
        if self.state in CYCLIC_STATES:
            self._go(NmtState.PRE_OPERATIONAL_1)

    def command(self, command_id: int) -> bool:
        """An NMT state command (DS 301 7.3.1.2.1) addressed to this node; True if it acted.

        NMT_GT2 NMTSwReset, GT4 NMTResetNode, GT5 NMTResetCommunication, GT6 (no command),
        GT7 NMTResetConfiguration: in every CN state. NMT_CT5 EnableReadyToOperate (PreOp2),
        CT6 StartNode (ReadyToOperate), CT7 StopNode (PreOp2, ReadyToOperate, Operational),
        CT8/CT10 EnterPreOperational2 (Operational, Stopped, ReadyToOperate: CT9).
        """
        s = self.state
        if command_id == NmtCommandId.SW_RESET:
            self._go(NmtState.GS_INITIALISING)
            self._reset(Reset.APPLICATION)
        elif command_id == NmtCommandId.RESET_NODE:
            self._reset(Reset.APPLICATION)
        elif command_id == NmtCommandId.RESET_COMMUNICATION:
            self._reset(Reset.COMMUNICATION)
        elif command_id == NmtCommandId.RESET_CONFIGURATION:
            self._reset(Reset.CONFIGURATION)
        elif command_id == NmtCommandId.ENABLE_READY_TO_OPERATE and s == NmtState.PRE_OPERATIONAL_2:
            self._go(NmtState.READY_TO_OPERATE)
        elif command_id == NmtCommandId.START_NODE and s == NmtState.READY_TO_OPERATE:
            self._go(NmtState.OPERATIONAL)
        elif command_id == NmtCommandId.STOP_NODE and s in (
            NmtState.PRE_OPERATIONAL_2,
            NmtState.READY_TO_OPERATE,
            NmtState.OPERATIONAL,
        ):
            self._go(NmtState.STOPPED)
        elif command_id == NmtCommandId.ENTER_PRE_OPERATIONAL_2 and s in (
            NmtState.READY_TO_OPERATE,
            NmtState.OPERATIONAL,
            NmtState.STOPPED,
        ):
            self._go(NmtState.PRE_OPERATIONAL_2)
        else:
            return False
        return True
