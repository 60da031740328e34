"""One EtherCAT slave controller (ESC): 64 KiB of registers and process memory, as on the wire.

What the ESC does is the Beckhoff ESC datasheet (section I "technology", section II "registers")
and ETG.1000.4 (data link layer: addressing, commands, working counter):

* addressing (ETG.1000.4 5.3, datasheet I 2.3): auto-increment commands act where ADP is 0 on
  arrival and every ESC increments ADP; configured-address commands act where ADP equals the
  station address 0x0010 or, when DL control 0x0100 bit 24 is set, the alias 0x0012; broadcast
  commands act everywhere and increment ADP; logical commands act through the FMMUs;
* commands and working counter (datasheet I Tables 5-7): a read adds 1, a write 1, a read-write
  1 for the read and 2 for the write (read before write); BRD/BRW OR the memory into the data;
  ARMW/FRMW read at the addressed ESC and write at every other one (+1 either way); a logical
  read replaces only the FMMU-mapped bits; an access counts if at least one byte or bit of it was
  successfully read or written (a SyncManager may deny it);
* registers 0x0000-0x0F7F are written through shadow buffers that take effect at the end of the
  frame (datasheet I 3.4); reads inside the frame see the old values; per-byte ECAT write masks
  follow section II (read-only and reserved bits keep their value, the access still counts);
* SyncManagers (datasheet I 8, II 2.14; their state and status in
  :mod:`emulator.esc.syncmanagers`): buffered (3-buffer) and mailbox mode, direction,
  "a buffer has to be accessed beginning with the start address", buffer exchange at the end of
  the frame that accessed the end address, the whole area locked while the PDI deactivates the
  SyncManager (0x0807 bit 0), configuration writable only while disabled;
* FMMUs (datasheet I 7, II 2.13): bit-wise logical->physical mapping, read and/or write, the
  lower-numbered FMMU wins a logical byte claimed twice;
* the SII EEPROM interface 0x0500-0x050F (datasheet I 11.2, II 2.11): ECAT/PDI ownership,
  read (8 bytes), write (one word, write enable in the same frame), reload, the error bits, and
  the configuration area A loaded at power-on with its CRC checked (else process memory stays
  inaccessible and DL status bit 0 clear): the commands and the load in
  :mod:`emulator.esc.eeprom`, over rows, each ESC with its own EEPROM image;
* DL control loop settings and DL status (datasheet I 3.1, II 2.4; :mod:`emulator.esc.dl`),
  ECAT event request 0x0210 ORed into each datagram's IRQ field through the mask 0x0200
  (datasheet I Table 3), and the ESC reset sequence 'R','E','S' in 0x0040.

* distributed clocks 0x0900-0x09FF in :mod:`emulator.esc.dc` (its hooks: reads refresh the
  registers, writes of 0x0900-0x0917 are events, SYNC0 samples when the inputs are opened);
* every configuration a frame can set is legal input: FMMU and SyncManager mappings are
  clipped to the 64 KiB address space, register writes are masked as whole integers, so the
  work per frame is bounded by the frame, not by what the configuration asks for.

The FMMU and SyncManager tables are decoded and logical accesses planned in
:mod:`emulator.esc.mapping`; register writes are cut into their parts, and what a write of the
registers with side effects does is said once, in :mod:`emulator.esc.write_plans`; what a
register read does besides the bytes is :func:`emulator.esc.registers.reads_dc` and
:func:`~emulator.esc.registers.cleared_events`. What a frame's register writes set off at its
end (SyncManager and FMMU tables, DL status, DC, EEPROM commands, AL control) and power-on are
written once, over rows of ESCs (:func:`commit_together`, :func:`power_on_together`): an ESC
on its own is a line of one.

Not modelled: watchdogs (registers only), MII management, write protection 0x0020/0x0030, the
circulating bit, UDP encapsulation and a second PDI. The slave application behind the PDI
(:class:`emulator.esc.pdi.Pdi`) is a :class:`emulator.slave.state_machine.PdiApplication`; the
skin patch's is :class:`SkinPatchApplication`.
"""

from __future__ import annotations

import struct
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from graphlib import CycleError, TopologicalSorter
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc.al import control_written, reactions, status, status_written
from emulator.esc.commands import (
    APRD,
    APRW,
    ARMW,
    BRD,
    BRW,
    BWR,
    FPRD,
    FPRW,
    FPWR,
    FRMW,
    LRD,
    LRW,
    LWR,
)
from emulator.esc.dc import DcClock, configure_together, registers_power_on
from emulator.esc.dl import dl_status
from emulator.esc.dl import port1_forwarding as port1_forwarding  # (moved there)
from emulator.esc.eeprom import config_area as config_area  # (these three moved there)
from emulator.esc.eeprom import config_writes as config_writes
from emulator.esc.eeprom import eeprom_read as eeprom_read
from emulator.esc.eeprom import execute_commands, power_on_interface
from emulator.esc.eeprom import load_config_areas as _load
from emulator.esc.mapping import (
    PLAN_CACHE_ENTRIES,
    Access,
    Caches,
    Fmmu,
    FmmuTable,
    LogicalPlan,
    Mailboxes,
    SmChange,
    SmTable,
    fmmu_table,
    remember,
    sm_change,
    sm_table,
    table_access,
)
from emulator.esc.registers import (
    ADDRESS_SPACE,
    DC_SYNC0_ACTIVE,
    EVENT_DL_STATUS,
    PROCESS_RAM,
    REG_AL_CODE,
    REG_AL_CONTROL,
    REG_AL_STATUS,
    REG_ALIAS,
    REG_DC_ACTIVATION,
    REG_DC_RECEIVE,
    REG_DL_CONTROL,
    REG_ECAT_EVENT,
    REG_ECAT_EVENT_MASK,
    REG_FMMU,
    REG_PU_ERRORS,
    REG_RESET_ECAT,
    REG_RW_OFFSET,
    REG_SM,
    REG_STATION,
    REG_TYPE,
    REG_WD_DIVIDER,
    REG_WD_PD,
    REG_WD_PDI,
    REG_WD_STATUS,
    REGISTER_END,
    SM_BYTES,
    SM_NO_BUFFER,
    EscConfig,
    Memory,
    cleared_events,
    reads_dc,
)
from emulator.esc.syncmanagers import (
    ECAT_EMPTIED,
    ECAT_OPENED_READ,
    ECAT_READ,
    ecat_completed,
    ecat_interrupt_pending,
    ecat_opened,
    pdi_read,
    pdi_wrote,
    through,
)
from emulator.esc.syncmanagers import SmRun as SmRun  # (moved there; the old name kept)
from emulator.esc.write_plans import (
    ERROR_COUNTERS,
    TOUCHES_FMMU,
    TOUCHES_SM,
    WritePlans,
    mark,
    write_masked,
    write_special,
)
from emulator.slave.sii import SlaveInfo, build_sii
from emulator.slave.state_machine import PdiApplication, SkinPatchApplication

__all__ = [
    "ADDRESS_SPACE",
    "PROCESS_RAM",
    "REGISTER_END",
    "EscConfig",
    "EscDevice",
    "TraceCopy",
]

_RESET_SEQUENCE: Final = b"RES"
_MAILBOX_EVENT: Final = -1  # EscDevice._reaction: a mailbox or SyncManager event, not AL control
# EscDevice._reaction: -2 - n, ECAT completed the buffer of write SyncManager n
_OUTPUTS_EVENT: Final = -2

# EscDevice's methods for its chain alone, public until the interface named what stays public
# (docs/interface.md, "EscDevice"): each old name still answers, with a DeprecationWarning
_RENAMED: Final = {
    "use_memory": "_use_memory",
    "use_span_row": "_use_span_row",
    "use_caches": "_use_caches",
    "finish_frame": "_finish_frame",
    "read_buffered": "_read_buffered",
    "row_access": "_access",
    "refresh_dc": "_refresh_dc",
    "row_cut": "_row_cut",
    "mailboxes_idle": "_mailboxes_idle",
    "clear_read_events": "_clear_read_events",
    "logical_unless_rows": "_logical_unless_rows",
    "write_shadow": "_write_shadow",
    "whole_plan": "_whole_plan",
    "react": "_reaction",
    "react_now": "_reactions_now",
    "use_fmmus": "_use_fmmus",
    "change_syncmanagers": "_change_syncmanagers",
    "finish_frames": "_finish_frames",
    "unfinished": "_unfinished",
    "al_control_together": "_al_control_together",
    "change_syncmanagers_together": "_change_syncmanagers_together",
    "sm_registers_written_together": "_sm_registers_written_together",
}

LRD_OR_LRW: Final = frozenset((LRD, LRW))  # the logical commands that read (read_buffered)
_LRD_KEY_SHIFT: Final = 16  # _lrd_key: the length (a datagram's 11 bits) below


def _lrd_key(lad: int, n: int) -> int:
    """The key of :attr:`EscDevice._lrd_plans` for an LRD of ``n`` bytes at ``lad``: an int,
    which hashes faster than a tuple (every ESC an LRD of the image reaches looks its plan
    up)."""
    return lad << _LRD_KEY_SHIFT | n


@dataclass(frozen=True, slots=True)
class TraceCopy:
    """Bytes an ESC copied from its memory into a frame (for timing models): a SyncManager's
    buffer, or memory no SyncManager controls (``sm`` -1: registers, or process RAM the
    application writes as plain memory, e.g. behind a SyncManager of length 1, which the ESC
    does not activate, datasheet II 2.14 0x0802)."""

    position: int  # the ESC's position in its chain
    sm: int  # SyncManager index, -1 for memory no SyncManager controls
    src: int  # offset in the SyncManager buffer; with sm -1 the physical address
    dst: int  # offset in the frame buffer
    length: int


def _bits_written(
    target: bytes | bytearray | memoryview,
    data_in: bytes,
    shift: int,
    mask: int,
    at: int,
    width: int,
) -> bytes:
    """A bit-wise FMMU write (:func:`emulator.esc.mapping.plan_logical`): the physical bytes
    ``target`` with the bits under ``mask`` taken from frame bytes [at, at + width) of
    ``data_in``, ``shift`` bits further on; the unmapped bits kept."""
    value = int.from_bytes(data_in[at : at + width], "little")
    value = value << shift if shift >= 0 else value >> -shift
    old = int.from_bytes(target, "little")
    return ((old & ~mask) | (value & mask)).to_bytes(len(target), "little")


class _Unmade:
    """SyncManagers changed but not made yet (:meth:`EscDevice._make_sms`). A class, not a
    NamedTuple: compiled (mypyc), it is made as a native object, where a NamedTuple runs its
    ``__new__`` as Python (a frame that changes the SyncManagers of every ESC makes one at
    each)."""

    __slots__ = ("by_start", "decoded", "fresh")

    def __init__(
        self, fresh: frozenset[int] | None, decoded: SmTable, by_start: tuple[int, ...]
    ) -> None:
        self.fresh = fresh  # the indices of those that start anew (None: all of them)
        self.decoded = decoded  # the decoded table
        self.by_start = by_start  # the order by start (SmChange.by_start)


def latches(ado: int, n: int) -> bool:
    """Whether a BWR or FPWR of ``n`` bytes at ``ado`` writes the receive time register
    0x0900-0x0903, and so latches the receive times (datasheet II 0x0900: "a write access with
    BWR or FPWR")."""
    return n > 0 and ado < REG_DC_RECEIVE + 4 and ado + n > REG_DC_RECEIVE


class EscDevice:
    """An ESC with its SII EEPROM and the application behind its PDI.

    Args:
        info: the slave's description; its SII image is built with :func:`build_sii`.
        config: identity registers.
        sii: a different EEPROM image (for example a corrupted one).
        app: the PDI application; a :class:`SkinPatchApplication` by default.
    """

    # every ESC of a chain is asked for its state in each frame: slots keep that quick (one
    # attribute more than 29 in an instance dict made every frame at 160 ESCs 10 % slower);
    # __dict__ still takes what a script sets on an ESC
    __slots__ = (
        "__dict__",
        "_active",
        "_caches",
        "_completed",
        "_fmmus",
        "_irq_batch",
        "_lrd_plans",
        "_mailbox_due",
        "_mailbox_hook",
        "_outputs_hook",
        "_reset_progress",
        "_reset_written",
        "_row",
        "_rows",
        "_sii_image",
        "_sms",
        "_span_row",
        "_unmade",
        "al_control_full",
        "app",
        "config",
        "dc",
        "firmware_queue",
        "fmmu_decoded",
        "fmmu_span",
        "info",
        "irq",
        "latch_due",
        "mem",
        "onward",
        "pdi_operational",
        "pending",
        "port1_link",
        "position",
        "sets_mac",
        "sii",
        "sm_areas",
        "trace",
        "write_plans",
    )

    def __init__(
        self,
        info: SlaveInfo,
        *,
        config: EscConfig | None = None,
        sii: bytes | None = None,
        app: PdiApplication | None = None,
    ) -> None:
        self.info = info
        self.config = config or EscConfig()
        self.app: PdiApplication = app if app is not None else SkinPatchApplication(info)
        self._sii_image = sii if sii is not None else build_sii(info)
        if len(self._sii_image) % 2 or len(self._sii_image) < 2 * 0x40:
            raise TopologyError(f"SII image of {len(self._sii_image)} bytes (even, >= 128)")
        # what this ESC decodes and plans once, its chain's when in one (use_caches)
        self._caches = Caches()
        self.write_plans = WritePlans.of(self._caches, self.config)  # how register writes are cut
        self.dc = DcClock()  # distributed clocks (dc.py); the chain shares its timebase
        self.position = 0  # set by the chain; used in traces
        self.port1_link = False  # set by the chain: a neighbour on port 1
        self.onward: bool | None = False  # cached forwards()
        self.sets_mac = True  # cached changes_source_mac
        self.trace: list[TraceCopy] | None = None
        self.mem: Memory = bytearray(ADDRESS_SPACE)
        # the memory as rows, and this ESC's row: what the behaviours written over rows of ESCs
        # take (a single ESC is a line of one; in a chain, a view of its row, use_memory)
        self._rows = (np.frombuffer(self.mem, np.uint8).reshape(1, -1), np.zeros(1, np.intp))
        self._row = slice(0, 1)  # the row as a slice: a view of it, no fancy indexing
        self.sii = bytearray(self._sii_image)  # non-volatile: survives an ESC reset
        self.pdi_operational = False
        # register writes of the current frame, committed at its end (datasheet I 3.4); the chain
        # appends a broadcast's one (address, data) to every ESC's list
        self.pending: list[tuple[int, bytes]] = []
        self._completed: list[SmRun] = []
        self._sms: list[SmRun | None] = []
        self._active: list[SmRun] = []  # enabled SMs with a buffer, sorted by start
        self._fmmus: tuple[Fmmu, ...] = ()
        self.fmmu_span = (0, 0)
        # fmmu_span as an array row, the chain's (use_span_row), seen through a memoryview (an
        # item set a third of numpy's): _set_span keeps both alike
        self._span_row = np.zeros(2, np.int64).data
        # the decoded FMMU table the ESC follows (fmmu_table): one object for every ESC whose
        # FMMU registers hold the same bytes, so that what follows from it is asked once
        self.fmmu_decoded = FmmuTable((), (0, 0))
        # LRDs that read one whole input buffer through one byte-wise FMMU (the process data
        # of every cycle): (frame offset, SyncManager, whether an FMMU writes there) per
        # (address, length), or None where the general path decides; worked out per FMMU and
        # SyncManager configuration, by _lrd_key(address, length)
        self._lrd_plans: dict[int, tuple[int, SmRun, bool] | None] = {}
        # the decoded SyncManager table the ESC's SyncManagers follow (sm_table)
        self.sm_areas: SmTable = ()
        # SyncManagers changed but not made yet, made when first needed (_make_sms); until
        # then _sms and _active are those before
        self._unmade: _Unmade | None = None
        self.irq = 0  # ECAT event request 0x0210 & mask 0x0200: ORed into IRQ fields
        # while the chain runs the firmware's reactions (EcatChain.run_firmware): where
        # update_irq notes this ESC, to be brought up to date with the others that reacted, over
        # their rows at once (no frame reads irq meanwhile); None: at once
        self._irq_batch: list[EscDevice] | None = None
        # a BWR or FPWR of the receive time register 0x0900 in this frame: the writes that
        # latch the receive times at the end of the frame (datasheet II 0x0900)
        self.latch_due = False
        # AL control 0x0120 written by ECAT and not read by the PDI yet: while device emulation
        # is off it is a mailbox, and ECAT cannot write it again (datasheet II 0x0120)
        self.al_control_full = False
        self._reset_progress = 0
        self._reset_written: int | None = None
        # the application's mailbox handler (emulator.slave.mailbox), run after frames that
        # completed a mailbox buffer or wrote SyncManager registers (repeat requests)
        self._mailbox_hook: Callable[[EscDevice], None] | None = getattr(
            self.app, "mailbox_event", None
        )
        self._mailbox_due = False
        # the application's handler of outputs: run after a frame that completed the buffer of
        # a process-data SyncManager ECAT writes (its buffer exchange, datasheet I 8.1)
        self._outputs_hook: Callable[[EscDevice, int], None] | None = getattr(
            self.app, "outputs_event", None
        )
        # whether the application samples its inputs at SYNC0 pulses (it has sync0, dc.py)
        self._samples = hasattr(self.app, "sync0")
        # where the application's reactions to a frame wait until the frame has passed (the
        # chain's list, EcatChain.run_firmware), or None: the application reacts at once
        self.firmware_queue: list[tuple[EscDevice, int]] | None = None
        self._power_on()

    def __getattr__(self, name: str) -> object:
        """A method by its old name (:data:`_RENAMED`), and the PDI's ``pdi_deactivate_sm(index,
        deactivate)``, now :meth:`pdi_deactivate_sms` of ``(index,)``, each with a
        DeprecationWarning; no other name is found here (called only where the usual look-up
        found nothing)."""
        if name == "pdi_deactivate_sm":
            warnings.warn(
                "EscDevice.pdi_deactivate_sm(i, v) is now EscDevice.pdi_deactivate_sms((i,), v)",
                DeprecationWarning,
                stacklevel=2,
            )
            return lambda index, deactivate: self.pdi_deactivate_sms((index,), deactivate)
        new = _RENAMED.get(name)
        if new is None:
            raise AttributeError(f"'EscDevice' object has no attribute {name!r}")
        warnings.warn(
            f"EscDevice.{name} is now EscDevice.{new}, its chain's own (docs/interface.md)",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(self, new)

    # --- power-on, EEPROM load ----------------------------------------------------------------
    def _power_on(self) -> None:
        """Reset values of section II, then the EEPROM load of datasheet I 11.1:
        :func:`power_on_together` of this ESC alone."""
        power_on_together([self])

    def _reset_state(self) -> None:
        """What the ESC keeps besides its memory, as at power-on: no SyncManager, no FMMU, no
        plan, no write pending, the clock's loop and pulses (:func:`power_on_together`)."""
        cfg = self.config
        self._sms = [None] * cfg.syncmanagers
        self._unmade = None
        self._active, self._fmmus, self.pending, self._completed = [], (), [], []
        self.latch_due = self.al_control_full = False
        self._forget_lrd_plans()
        self.sm_areas = ()
        self._set_span((0, 0))
        self.fmmu_decoded = FmmuTable((), (0, 0))
        self.dc.reset()

    # --- properties the chain and the PDI application use ---------------------------------------
    @property
    def station(self) -> int:
        """Configured station address (0x0010)."""
        return self.mem[REG_STATION] | self.mem[REG_STATION + 1] << 8

    @property
    def alias(self) -> int:
        """Configured station alias (0x0012)."""
        return self.mem[REG_ALIAS] | self.mem[REG_ALIAS + 1] << 8

    @property
    def al_status(self) -> int:
        """AL status (0x0130): state in bits 0-3, error indication bit 4 (:func:`al.status`)."""
        return status(self.mem)

    @property
    def al_status_code(self) -> int:
        """AL status code (0x0134)."""
        return self.mem[REG_AL_CODE] | self.mem[REG_AL_CODE + 1] << 8

    @property
    def dc_sampling(self) -> bool:
        """SYNC0 is active and the application samples at its pulses (dc.py): cyclic operation
        and SYNC0 activated (0x0981 bits 0 and 1), read here, not through dc.py, which runs as
        Python: every ESC an LRD of the image reaches asks this (such a call cost a tenth of
        that LRD's instructions at 160 ESCs, benchmarks/README)."""
        active = self.mem[REG_DC_ACTIVATION] & DC_SYNC0_ACTIVE == DC_SYNC0_ACTIVE
        return active and self._samples

    @property
    def changes_source_mac(self) -> bool:
        """DL control bit 0 = 1: the processing unit sets SOURCE_MAC[1] (datasheet II 2.4.1)."""
        return bool(self.mem[REG_DL_CONTROL] & 0x01)

    def forwards(self) -> bool | None:
        """Where a processed frame goes from port 1 (datasheet I 3.1, DL control bits 10-11).

        Returns:
            True: out of port 1 to the next ESC; False: the loop is closed and the frame returns
            towards the master; None: port 1 is forced open without a link, the frame is lost.
        """
        return self.onward

    def _use_memory(
        self,
        row: memoryview,
        *,
        line: npt.NDArray[np.uint8] | None = None,
        index: int = 0,
    ) -> None:
        """Keep the 64 KiB in ``row`` from now on (its content now): the chain holds every ESC's
        memory as one array, so that a broadcast reads or commits all of them at once; ``line``
        that array, whose row ``index`` is ``row`` (what works over rows of many ESCs at once
        takes the ESC's row of it, :func:`power_on_together`)."""
        if row.nbytes != ADDRESS_SPACE or row.format != "B" or row.readonly:
            raise TopologyError("ESC memory: a writable row of 64 KiB bytes")
        if isinstance(self.mem, memoryview):  # the other chain would read a row left behind
            raise TopologyError(f"ESC {self.info.serial}: already in a chain")
        row[:] = self.mem
        self.mem = row
        if line is None:
            self._rows = (np.frombuffer(row, np.uint8).reshape(1, -1), np.zeros(1, np.intp))
            self._row = slice(0, 1)
        else:
            self._rows = (line, np.full(1, index, np.intp))
            self._row = slice(index, index + 1)

    def _use_span_row(self, row: npt.NDArray[np.int64]) -> None:
        """Keep :attr:`fmmu_span` in ``row`` (two int64) too, from now on: the chain holds every
        ESC's span as one array, to find the ESCs a logical datagram may concern at once."""
        self._span_row = row.data
        self._set_span(self.fmmu_span)

    def _use_caches(self, caches: Caches) -> None:
        """Decode and plan in ``caches`` from now on: its chain's, shared by the ESCs of that
        chain alone (what it decoded before stays its own)."""
        self._caches = caches
        self.write_plans = WritePlans.of(caches, self.config)

    def registers(self, addr: int, length: int) -> bytes:
        """The committed register/memory bytes (no side effects; for tests and tools)."""
        return bytes(self.mem[addr : addr + length])

    def sm_registers(self, index: int) -> tuple[int, int, int, int]:
        """(start, length, control, activate) of SyncManager ``index``."""
        start, length, control, _, activate = struct.unpack_from(
            "<HHBBB", self.mem, REG_SM + SM_BYTES * index
        )
        return start, length, control, activate

    # --- the PDI side (the slave application) ---------------------------------------------------
    def pdi_set_al_status(self, state: int, *, error: bool, code: int) -> None:
        """The application writes AL status and AL status code (:func:`al.status_written`)."""
        if status_written(self.mem, state, error=error, code=code):
            self.update_irq()

    def pdi_deactivate_sms(self, indices: Iterable[int], deactivate: bool) -> None:
        """PDI control 0x0807 bit 0: lock (True) or release SyncManagers ``indices`` (datasheet
        I 8.7), the table rebuilt once."""
        if self._unmade is not None:
            self._make_sms()
        mem, bit, changed = self.mem, 0x01 if deactivate else 0, False
        for index in indices:
            addr = REG_SM + SM_BYTES * index + 7
            if mem[addr] & 0x01 != bit:
                mem[addr] = (mem[addr] & ~0x01) | bit
                self._sms[index] = None  # the SyncManager's state is reset
                changed = True
        if changed:
            self._rebuild_sms()
            if self._unmade is not None:  # now: the reset ones, kept, get their status here
                self._make_sms()

    def pdi_set_repeat_ack(self, index: int, value: bool) -> None:
        """PDI control 0x0807 bit 1: the repeat acknowledge of a mailbox (datasheet II 2.14.7)."""
        addr = REG_SM + SM_BYTES * index + 7
        self.mem[addr] = (self.mem[addr] & ~0x02) | (0x02 if value else 0)

    def pdi_write(self, addr: int, data: bytes) -> None:
        """The application writes memory; a whole read-SM buffer is a buffer exchange."""
        self.mem[addr : addr + len(data)] = data
        self._pdi_wrote(addr, len(data))

    def _pdi_wrote(self, addr: int, n: int) -> None:
        """After the PDI wrote ``n`` bytes at ``addr``: each read SyncManager whose whole buffer
        that is exchanges it (datasheet I 8.1; :func:`pdi_wrote`), a mailbox's then full, and
        its interrupt for ECAT follows (:meth:`_sm_event`)."""
        if self._unmade is not None:
            self._make_sms()
        for sm in self._active:
            if sm.start == addr and sm.length == n and not sm.ecat_writes:
                sm = self._own(sm)  # the ESC's own, in the list's place
                st = REG_SM + SM_BYTES * sm.index + 5
                if sm.mailbox:
                    sm.full = True
                self.mem[st] = pdi_wrote(self.mem[st], sm.mailbox)
                if sm.ecat_interrupt:
                    self._sm_event(sm.index)

    def pdi_read(self, addr: int, length: int) -> bytes:
        """The application reads memory (outputs a master committed to a write SyncManager)."""
        if self._unmade is not None:
            self._make_sms()
        for sm in self._active:
            if sm.start == addr and sm.ecat_writes:
                st = REG_SM + SM_BYTES * sm.index + 5
                self.mem[st] = pdi_read(self.mem[st], sm.mailbox)
                if sm.mailbox and sm.full:  # (a shared one is as new, empty: nothing to change)
                    sm.full = False
                if sm.ecat_interrupt:
                    self._sm_event(sm.index)
        return bytes(self.mem[addr : addr + length])

    # --- frame processing -----------------------------------------------------------------------
    def end_frame(self) -> None:
        """The frame has passed: shadow registers take effect, buffers change (datasheet I 3.4)."""
        if not (self.pending or self._completed or self._reset_written is not None):
            if self._reset_progress:  # a frame that does not continue 'R','E','S' cancels it
                self._reset_progress = 0
                self.mem[REG_RESET_ECAT] = 0
            return
        if self.pending:  # through the ECAT write masks, setting off what they set off (I 3.4)
            commit_together([self], self._rows[0], self._rows[1])
        self._finish_frame()

    def _finish_frame(self) -> None:
        """:meth:`end_frame` after the register writes took effect: buffer exchanges, the
        mailbox, the reset sequence (the chain commits the writes of many ESCs at once)."""
        if self._completed:
            for sm in self._completed:
                self._finish_buffer(sm)
            self._completed.clear()
        if self._mailbox_due:
            self._mailbox_due = False
            if self._mailbox_hook is not None:
                self._react(_MAILBOX_EVENT)
        if self._reset_written is None:
            self._reset_progress = 0
        else:
            expected = _RESET_SEQUENCE[self._reset_progress]
            if self._reset_written == expected:
                self._reset_progress += 1
            else:
                self._reset_progress = 1 if self._reset_written == _RESET_SEQUENCE[0] else 0
            self._reset_written = None
            if self._reset_progress == len(_RESET_SEQUENCE):
                self._reset_progress = 0
                self._reactions_now()  # what the application was to do before the reset
                self._power_on()
        self.mem[REG_RESET_ECAT] = self._reset_progress

    def _finish_unless_reset(self) -> bool:
        """:meth:`_finish_frame` up to a reset it completes: True (the application reacted to
        what it was to before), the power-on left to the caller, which does many at once."""
        if (
            self._reset_progress == len(_RESET_SEQUENCE) - 1
            and self._reset_written == _RESET_SEQUENCE[-1]
        ):
            self._reset_written = None
            self._reset_progress = 0
            self._finish_frame()  # buffers, mailbox; no reset written now: 0x0040 = 0
            self._reactions_now()
            return True
        self._finish_frame()
        return False

    @staticmethod
    def _finish_frames(devices: list[EscDevice]) -> None:
        """:meth:`_finish_frame` at each of ``devices``, whose reset register 0x0040 the chain
        set to 0 (over the rows): one that is only to run its mailbox handler (no buffer
        completed, no reset written or under way) just has it run (or queued), as
        :meth:`_finish_frame` would."""
        resets: list[EscDevice] = []
        for dev in devices:
            if dev._completed or dev._reset_written is not None or dev._reset_progress:
                if dev._reset_written is None:
                    dev._finish_frame()
                elif dev._finish_unless_reset():
                    resets.append(dev)
            elif dev._mailbox_due:
                dev._mailbox_due = False
                if dev._mailbox_hook is not None:
                    dev._react(_MAILBOX_EVENT)
        if resets:
            power_on_together(resets)

    @staticmethod
    def _unfinished(devices: list[EscDevice]) -> list[EscDevice]:
        """Those of ``devices`` whose :meth:`_finish_frame` does more than show no reset under
        way (0x0040 = 0): a buffer completed, the mailbox handler due, the reset register
        written or a reset sequence under way (the chain sets 0x0040 of the others at once)."""
        return [
            dev
            for dev in devices
            if dev._completed
            or dev._mailbox_due
            or dev._reset_written is not None
            or dev._reset_progress
        ]

    def process(
        self, cmd: int, adp: int, ado: int, buf: bytearray, off: int, n: int
    ) -> tuple[int, int]:
        """Execute one datagram whose data is ``buf[off:off+n]``, in place.

        Returns:
            (the ADP this ESC passes on, the working-counter increment).
        """
        if cmd <= APRW or cmd == ARMW:  # auto increment (NOP is 0: untouched)
            if cmd == 0:
                return adp, 0
            out = (adp + 1) & 0xFFFF
            if cmd == ARMW:
                if adp == 0:
                    return out, self._read(ado, buf, off, n, False)
                return out, self._write(ado, bytes(buf[off : off + n]))
            if adp != 0:
                return out, 0
            return out, self._physical(cmd - APRD, ado, buf, off, n)
        if cmd <= FPRW or cmd == FRMW:  # configured station address or alias
            mem = self.mem
            hit = adp == mem[REG_STATION] | mem[REG_STATION + 1] << 8 or (
                mem[REG_DL_CONTROL + 3] & 0x01 and adp == mem[REG_ALIAS] | mem[REG_ALIAS + 1] << 8
            )
            if hit and cmd == FPWR and latches(ado, n):
                self.latch_due = True
            if cmd == FRMW:
                if hit:
                    return adp, self._read(ado, buf, off, n, False)
                return adp, self._write(ado, bytes(buf[off : off + n]))
            return adp, (self._physical(cmd - FPRD, ado, buf, off, n) if hit else 0)
        if cmd <= BRW:  # broadcast
            if cmd == BWR and latches(ado, n):
                self.latch_due = True
            return (adp + 1) & 0xFFFF, self._physical(cmd - BRD, ado, buf, off, n, broadcast=True)
        if cmd <= LRW:
            lad = adp | ado << 16
            lo, hi = self.fmmu_span  # none of the FMMUs maps a byte outside it
            if lad >= hi or lad + n <= lo:
                return adp, 0
            return adp, self._logical(cmd, lad, buf, off, n)
        return adp, 0  # reserved command values: ignored

    def _physical(
        self, kind: int, ado: int, buf: bytearray, off: int, n: int, *, broadcast: bool = False
    ) -> int:
        """kind 0 read, 1 write, 2 read-write (datasheet I Table 7)."""
        if kind == 0:
            return self._read(ado, buf, off, n, broadcast)
        if kind == 1:
            return self._write(ado, bytes(buf[off : off + n]))
        data_in = bytes(buf[off : off + n])  # read before write; the write uses Data In
        r = self._read(ado, buf, off, n, broadcast)
        rw_offset = self.mem[REG_RW_OFFSET] | self.mem[REG_RW_OFFSET + 1] << 8
        w = self._write((ado + rw_offset) & 0xFFFF, data_in)
        return r + 2 * w

    # --- physical access ------------------------------------------------------------------------
    def _read(self, addr: int, buf: bytearray, off: int, n: int, or_mode: bool) -> int:
        segments = self._read_phys(addr, n)
        if not segments:
            return 0
        for rel, data, sm, src in segments:
            at = off + rel
            if or_mode:
                k = len(data)
                merged = int.from_bytes(buf[at : at + k], "little") | int.from_bytes(data, "little")
                buf[at : at + k] = merged.to_bytes(k, "little")
            else:
                buf[at : at + len(data)] = data
            if self.trace is not None:
                self.trace.append(TraceCopy(self.position, sm, src, at, len(data)))
        return 1

    def _read_phys(self, addr: int, n: int) -> list[tuple[int, bytes, int, int]]:
        """Readable parts of [addr, addr+n): (offset in the access, bytes, SM index or -1, offset
        in the SM buffer or, with -1, the physical address). Register reads have their side
        effects here."""
        end = min(addr + n, ADDRESS_SPACE)
        mem = self.mem
        out: list[tuple[int, bytes, int, int]] = []
        pos = addr
        if pos < REGISTER_END:
            hi = min(end, REGISTER_END)
            if reads_dc(pos, hi):
                self.dc.refresh(mem, pos, hi)  # DC registers run with the clock
            out.append((0, bytes(mem[pos:hi]), -1, pos))
            events = cleared_events(pos, hi)
            if events:
                self._clear_event(events)
            pos = hi
        if pos >= end:
            return out
        if self._unmade is not None:
            self._make_sms()
        for sm in self._active:
            if sm.end <= pos:
                continue
            if sm.start >= end:
                break
            if sm.start > pos:
                self._plain_read(out, addr, pos, sm.start)
                pos = sm.start
            hi = min(sm.end, end)
            self._sm_read(out, sm, addr, pos, hi)
            pos = hi
        if pos < end:
            self._plain_read(out, addr, pos, end)
        return out

    def _plain_read(
        self, out: list[tuple[int, bytes, int, int]], addr: int, lo: int, hi: int
    ) -> None:
        if not self.pdi_operational:
            hi = min(hi, PROCESS_RAM)  # no process RAM before the EEPROM loaded (I 11.2.1)
        if lo < hi:
            out.append((lo - addr, bytes(self.mem[lo:hi]), -1, lo))

    def _sm_read(
        self, out: list[tuple[int, bytes, int, int]], sm: SmRun, addr: int, lo: int, hi: int
    ) -> None:
        if sm.ecat_writes or sm.locked:
            return  # a write SyncManager's buffer is not readable from ECAT; a locked one at all
        st = REG_SM + SM_BYTES * sm.index + 5
        if lo == sm.start:
            if sm.mailbox and not sm.full:
                return  # "read w. failure (mailbox empty)"
            sm = self._own(sm)  # before the application writes it (a sample at SYNC0)
            if not sm.mailbox and self.dc_sampling:
                pulse = self.dc.sample_due(self.mem)
                if pulse is not None:  # a SYNC0 pulse since the last sample (dc.py)
                    self.app.sync0(self, pulse)  # type: ignore[attr-defined]
            sm.open = True
            sm.buf = bytes(self.mem[sm.start : sm.end])
            self.mem[st] = ecat_opened(self.mem[st], False)  # (as read_buffers does over rows)
            if sm.ecat_interrupt:
                self._sm_event(sm.index)
        elif not sm.open:
            return  # "a buffer has to be accessed beginning with the start address"
        data = self.mem[lo:hi] if sm.buf is None else sm.buf[lo - sm.start : hi - sm.start]
        out.append((lo - addr, bytes(data), sm.index, lo - sm.start))
        if hi == sm.end and not sm.complete:
            sm.complete = True
            self._completed.append(sm)

    def _write(self, addr: int, data: bytes) -> int:
        """Write ``data`` at ``addr``; 1 if any byte was accepted."""
        end = min(addr + len(data), ADDRESS_SPACE)
        ok = 0
        pos = addr
        if pos < REGISTER_END:
            hi = min(end, REGISTER_END)
            self._write_shadow(((pos, data[: hi - addr]),))
            ok = 1
            pos = hi
        if pos >= end:
            return ok
        if self._unmade is not None:
            self._make_sms()
        for sm in self._active:
            if sm.end <= pos:
                continue
            if sm.start >= end:
                break
            if sm.start > pos:
                ok |= self._plain_write(addr, data, pos, sm.start)
                pos = sm.start
            hi = min(sm.end, end)
            ok |= self._sm_write(sm, addr, data, pos, hi)
            pos = hi
        if pos < end:
            ok |= self._plain_write(addr, data, pos, end)
        return ok

    def _plain_write(self, addr: int, data: bytes, lo: int, hi: int) -> int:
        if not self.pdi_operational:
            hi = min(hi, PROCESS_RAM)
        if lo >= hi:
            return 0
        self.mem[lo:hi] = data[lo - addr : hi - addr]  # user and process RAM: no shadow buffer
        return 1

    def _sm_write(self, sm: SmRun, addr: int, data: bytes, lo: int, hi: int) -> int:
        if not sm.ecat_writes or sm.locked:
            return 0  # a read SyncManager's buffer is written by the PDI only
        st = REG_SM + SM_BYTES * sm.index + 5
        if lo == sm.start:
            if sm.mailbox and sm.full:
                return 0  # "write w. failure (mailbox full)"
            sm = self._own(sm)
            sm.open = True
            sm.buf = bytearray(self.mem[sm.start : sm.end])
            self.mem[st] = ecat_opened(self.mem[st], True)
            if sm.ecat_interrupt:
                self._sm_event(sm.index)
        elif not sm.open:
            return 0
        assert isinstance(sm.buf, bytearray)
        sm.buf[lo - sm.start : hi - sm.start] = data[lo - addr : hi - addr]
        if hi == sm.end and not sm.complete:
            sm.complete = True
            self._completed.append(sm)
        return 1

    def _finish_buffer(self, sm: SmRun) -> None:
        """Buffer exchange after the frame that accessed the end address (datasheet I 8.1); a
        read SyncManager's is :func:`finish_reads`."""
        if not sm.ecat_writes:
            finish_reads([self], [sm], self._rows[0], self._row)
            return
        sm.complete = False
        if not self._still(sm):
            return
        st = REG_SM + SM_BYTES * sm.index + 5
        sm.open = False
        self._mailbox_due = self._mailbox_due or sm.mailbox
        assert isinstance(sm.buf, bytearray)
        self.mem[sm.start : sm.end] = sm.buf
        self.mem[st] = ecat_completed(self.mem[st], True, sm.mailbox)
        if sm.mailbox:
            sm.full = True
        elif self._outputs_hook is not None:  # the SyncManager's event for the PDI
            self._react(_OUTPUTS_EVENT - sm.index)
        sm.buf = None  # (the interrupt for ECAT, 0x0210, is as it was: _sm_event)

    def _still(self, sm: SmRun) -> bool:
        """Whether ``sm`` is still this ESC's SyncManager at the end of the frame that completed
        its buffer: not started anew by a change of the table the frame wrote (nor by a reset)."""
        if self._unmade is not None:
            if self._unmade.fresh is None:
                return False  # every SyncManager starts anew
            self._make_sms()
        return self._sms[sm.index] is sm

    # --- logical access through the FMMUs ------------------------------------------------------
    def _read_buffered(self, lad: int, buf: bytearray, off: int, n: int, cmd: int = LRD) -> bool:
        """An LRD of ``n`` bytes at ``lad`` (data at ``buf[off:]``) in its common case, the
        whole buffer of one read SyncManager (:meth:`_plan_lrd`): done, with the working counter
        to count 1, when True; False leaves the LRD to :meth:`process` (the chain asks this
        first, for every ESC an LRD or LRW of the process image reaches). An LRW (``cmd``) that
        no FMMU of this ESC writes is that LRD: it reads alike and counts 1 (ETG.1000.4 Table 14,
        +1 for a read, +2 for a write)."""
        found = None if self.dc_sampling else self._whole_plan(lad, n, cmd)
        if found is None:
            return False
        at, sm = found
        self._read_whole(sm, buf, off + at)
        return True

    def _read_whole(self, sm: SmRun, buf: bytearray, at: int) -> None:
        """:func:`read_buffers` at this ESC alone, its buffer exchange at the end of the frame
        (:meth:`_finish_frame`)."""
        due = not sm.complete
        read_buffers([self], [sm], 0, [at], self._rows[0], self._row, buf)
        if due:
            self._completed.append(sm)

    def _access(self, cmd: int, lad: int, n: int) -> Access:
        """A logical access by this ESC's FMMUs (:func:`plan_logical`), worked out once per
        FMMU table and access (:func:`table_access`), with what the chain may do over the rows
        (:meth:`Access.rows`, :func:`emulator.esc.mapping.esc_row_access`), remembered for the
        SyncManager table, memory top and register write plans last asked about (ESCs
        configured alike ask alike): :attr:`Access.cut`, the plan cut, of a plain access, or of
        one that is plain but for reads of DL or AL status, whose events
        (:attr:`Access.events`) the ESC then clears (:meth:`_clear_read_events`), but for
        mailboxes (:attr:`Access.mailboxes`) that must be idle (:meth:`_row_cut`), but for a
        read of DC registers (:attr:`Access.dc`), which the ESC brings up to the frame's time
        first (:meth:`_refresh_dc`), and but for writes of registers (:attr:`Access.shadow`),
        whose bytes go among its shadow writes (:meth:`_write_shadow`)."""
        found = table_access(self._caches, self.fmmu_decoded, cmd, lad, n)
        top = ADDRESS_SPACE if self.pdi_operational else PROCESS_RAM  # I 11.2.1
        found.rows(self.sm_areas, top, self.write_plans)
        return found

    def _refresh_dc(self, registers: tuple[tuple[int, int], ...]) -> None:
        """Bring the DC registers [lo, hi) of ``registers`` (:attr:`Access.dc`) up to the
        frame's time, as before a read of them (:meth:`DcClock.refresh`)."""
        for lo, hi in registers:
            self.dc.refresh(self.mem, lo, hi)

    def _row_cut(self, found: Access) -> LogicalPlan | None:
        """``found.cut`` (:meth:`_access`) when it holds at this ESC now: its mailboxes idle
        (:meth:`_mailboxes_idle`); else None."""
        if found.mailboxes and not self._mailboxes_idle(found.mailboxes):
            return None
        return found.cut

    def _mailboxes_idle(self, mailboxes: Mailboxes) -> bool:
        """Whether ECAT can access none of ``mailboxes`` ((SyncManager index, side 0 read /
        1 write), :func:`emulator.esc.mapping.esc_row_access`) now: a read mailbox empty,
        a write mailbox full (neither is then open: ECAT opens a mailbox only in the other
        state, and only the buffer's end changes it back). Then a logical access there reads
        or writes nothing and changes no state: what :meth:`_sm_read` and :meth:`_sm_write` do
        with a failed access (datasheet I 8.2.1), wherever in the buffer it starts."""
        fresh: frozenset[int] | tuple[()] = ()
        if self._unmade is not None:  # one that starts anew has an empty mailbox
            if self._unmade.fresh is None:
                return all(side == 0 for _, side in mailboxes)
            fresh = self._unmade.fresh
        sms = self._sms
        for index, side in mailboxes:
            if index in fresh:
                if side != 0:
                    return False
                continue
            sm = sms[index]
            if sm is None or sm.full != (side == 1):
                return False
        return True

    def _clear_read_events(self, events: int) -> bool:
        """ECAT read the registers that clear ``events`` (0x0210 bits: DL status, AL status;
        datasheet I Table 3): whether the event request to the master (:attr:`irq`) changed."""
        before = self.irq
        self._clear_event(events)
        return self.irq != before

    def _logical_unless_rows(
        self, cmd: int, lad: int, buf: bytearray, off: int, n: int
    ) -> int | Access:
        """A logical datagram (data ``buf[off:off+n]``) as :meth:`process` does it: the working
        counter's increment; but when the chain may do it over the rows (:meth:`_access`),
        that access, untouched, for the chain to do it together with the ESCs after this one."""
        if cmd in LRD_OR_LRW and self._read_buffered(lad, buf, off, n, cmd):
            return 1
        found = self._access(cmd, lad, n)
        if self._row_cut(found) is not None:
            return found
        return self._through(found.plan, cmd, buf, off, n)

    def _write_shadow(self, entries: Iterable[tuple[int, bytes]]) -> None:
        """ECAT writes registers: each (address, bytes), below 0x0F80, into the shadow writes
        (:attr:`pending`; the register bytes of every :meth:`_write`); a byte written into the
        reset register 0x0040 counts towards a reset (datasheet II 2.3), the last one of the
        frame."""
        for addr, data in entries:
            self.pending.append((addr, data))
            if addr <= REG_RESET_ECAT < addr + len(data):
                self._reset_written = data[REG_RESET_ECAT - addr]

    def _logical(self, cmd: int, lad: int, buf: bytearray, off: int, n: int) -> int:
        if cmd in LRD_OR_LRW and self._read_buffered(lad, buf, off, n, cmd):
            return 1
        return self._through(self._access(cmd, lad, n).plan, cmd, buf, off, n)

    def _through(self, plan: LogicalPlan, cmd: int, buf: bytearray, off: int, n: int) -> int:
        """A logical access through the FMMUs by ``plan`` (:func:`plan_logical`)."""
        reads, writes = plan
        r = w = 0
        data_in = bytes(buf[off : off + n]) if writes else b""  # the write uses Data In
        for bytewise, phys, size, shift, mask, at, width in reads:
            if bytewise:
                r |= self._read(phys, buf, off + at, size, False)
            else:
                r |= self._bit_read(phys, size, shift, mask, buf, off + at, width)
        if writes:
            for bytewise, phys, size, shift, mask, at, width in writes:
                if bytewise:
                    w |= self._write(phys, data_in[at : at + size])
                else:
                    old = self.mem[phys : phys + size]
                    w |= self._write(phys, _bits_written(old, data_in, shift, mask, at, width))
        if cmd == LRD:
            return r
        if cmd == LWR:
            return w
        return r + 2 * w

    def _bit_read(
        self, first: int, count: int, shift: int, mask: int, buf: bytearray, off: int, n: int
    ) -> int:
        """A bit-wise FMMU read (:func:`plan_logical`): the readable bits of physical bytes
        [first, first + count), shifted to their bits in frame bytes [off, off + n), replace
        those under ``mask``."""
        segments = self._read_phys(first, count)
        if not segments:
            return 0
        value = valid = 0
        for rel, data, _, _ in segments:
            value |= int.from_bytes(data, "little") << (8 * rel)
            valid |= ((1 << (8 * len(data))) - 1) << (8 * rel)
        if shift >= 0:
            value, valid = value >> shift, valid >> shift
        else:
            value, valid = value << -shift, valid << -shift
        mask &= valid
        frame = int.from_bytes(buf[off : off + n], "little")
        frame = (frame & ~mask) | (value & mask)
        buf[off : off + n] = frame.to_bytes(n, "little")
        return 1

    def _plan_lrd(self, key: int) -> tuple[int, SmRun, bool] | None:
        """How an LRD of ``key`` = :func:`_lrd_key` (address, length) reads, when it is
        the common case the general path (:func:`plan_logical`, :meth:`_read_phys`,
        :meth:`_sm_read`) would take one way: one read FMMU, byte-wise, maps part of it onto exactly the whole
        buffer of a buffered read SyncManager in process memory, which no other SyncManager
        overlaps: the frame offset, the SyncManager, and whether a write FMMU meets it too (an
        LRW there is not that LRD)."""
        lad, n = key >> _LRD_KEY_SHIFT, key & 0xFFFF
        plan: tuple[int, SmRun, bool] | None = None
        reads = [f for f in self._fmmus if f.reads and f.log_start < lad + n and f.log_end > lad]
        if len(reads) == 1 and reads[0].bytewise:
            log_start, log_end, phys = reads[0].log_start, reads[0].log_end, reads[0].phys
            lo, hi = max(lad, log_start), min(lad + n, log_end)
            at, end = phys + (lo - log_start), phys + (hi - log_start)
            if self._unmade is not None:
                self._make_sms()
            hit = [sm for sm in self._active if sm.start < end and sm.end > at]
            if (
                at >= REGISTER_END
                and len(hit) == 1
                and (hit[0].start, hit[0].end) == (at, end)
                and not (hit[0].mailbox or hit[0].ecat_writes)
            ):
                writes = any(
                    f.writes and f.log_start < lad + n and f.log_end > lad for f in self._fmmus
                )
                plan = (lo - lad, self._own(hit[0]), writes)  # whose state the reads change
        return remember(self._lrd_plans, key, plan, PLAN_CACHE_ENTRIES)

    def _whole_plan(self, lad: int, n: int, cmd: int = LRD) -> tuple[int, SmRun] | None:
        """Whether an LRD (or an LRW, ``cmd``) of ``n`` bytes at ``lad`` is, at this ESC, its
        common case, the whole buffer of one read SyncManager (:meth:`_plan_lrd`), which
        :func:`read_buffers` reads (here and
        over rows of ESCs): (the buffer's offset in the datagram's data, the SyncManager); else
        None. An LRW that no FMMU of this ESC writes is that LRD: it reads alike and counts 1
        (ETG.1000.4 Table 14, +1 for a read, +2 for a write). What holds while the FMMUs and
        SyncManagers do (:attr:`emulator.esc.mapping.Caches.layouts`); the reader asks apart
        whether the ESC samples its inputs at SYNC0 now (:attr:`dc_sampling`)."""
        if self.trace is not None:
            return None
        key = _lrd_key(lad, n)
        plan = self._lrd_plans.get(key)  # one look-up where a plan is known
        if plan is None and key not in self._lrd_plans:
            plan = self._plan_lrd(key)
        if plan is None:
            return None
        at, sm, written = plan
        if sm.locked or (cmd != LRD and written):
            return None
        return at, sm

    # --- shadow registers and their side effects ------------------------------------------------
    @staticmethod
    def _al_control_together(
        devices: Sequence[EscDevice], values: Sequence[int], pdi_control: Sequence[int]
    ) -> None:
        """After a frame wrote AL control (0x0120), at each of ``devices``, with its AL control
        value and PDI control byte 0x0141: :func:`emulator.esc.al.reactions`, the firmware's
        held (:meth:`_hold`)."""
        EscDevice._hold(reactions(devices, values, pdi_control))

    @staticmethod
    def _hold(values: list[tuple[EscDevice, int]]) -> None:
        """Each (ESC, AL control value) of ``values`` to its firmware (:meth:`_react`): in one
        go where the ESCs share one queue (the chain's)."""
        if not values:
            return
        queue = values[0][0].firmware_queue
        if queue is not None and all(dev.firmware_queue is queue for dev, _ in values):
            queue.extend(values)
        else:
            for dev, what in values:
                dev._react(what)

    def _react(self, what: int) -> None:
        """The application reacts to the frame (:meth:`_reaction`), once the frame has passed when
        the chain holds its reactions (:attr:`firmware_queue`), else at once."""
        if self.firmware_queue is None:
            self._reaction(what)
        else:
            self.firmware_queue.append((self, what))

    def _reaction(self, what: int) -> None:
        """The application's reaction to a frame: to a write of AL control with value ``what``
        (the ESM, ETG.1000.6 6.4), to a mailbox or SyncManager event (``what`` -1), or to the
        buffer of process-data SyncManager n that ECAT completed (``what`` -2 - n): what the
        slave's firmware does after the ESC signalled the event (datasheet I 3.4, 8.1)."""
        if what == _MAILBOX_EVENT:
            assert self._mailbox_hook is not None
            self._mailbox_hook(self)
        elif what <= _OUTPUTS_EVENT:
            assert self._outputs_hook is not None
            self._outputs_hook(self, _OUTPUTS_EVENT - what)
        else:
            self.al_control_full = False  # the firmware reads AL control: ECAT may write again
            self.app.al_control(self, what)

    def _reactions_now(self) -> None:
        """The reactions of this ESC's application still held (:attr:`firmware_queue`), in
        order: before an ESC reset, which the firmware would have seen after them."""
        queue = self.firmware_queue
        if not queue or all(dev is not self for dev, _ in queue):
            return
        mine = [what for dev, what in queue if dev is self]
        queue[:] = [(dev, what) for dev, what in queue if dev is not self]
        for what in mine:
            self._reaction(what)

    def _use_fmmus(self, decoded: FmmuTable) -> None:
        """The FMMUs follow ``decoded``, their register bytes decoded (:func:`fmmu_table`; the
        chain decodes the tables of many ESCs at once, :func:`emulator.esc.together.
        commit_together`)."""
        self._fmmus = decoded.fmmus
        self._set_span(decoded.span)
        self.fmmu_decoded = decoded
        self._forget_lrd_plans()

    def _forget_lrd_plans(self) -> None:
        """The FMMUs or SyncManagers changed: the LRD plans (:meth:`_plan_lrd`) no longer hold,
        here nor in the chain's plans made of them (:attr:`Caches.layouts`)."""
        self._lrd_plans.clear()
        self._caches.layouts += 1

    def _set_span(self, span: tuple[int, int]) -> None:
        """:attr:`fmmu_span` and its row of the chain's array (:meth:`_use_span_row`)."""
        self.fmmu_span = span
        row = self._span_row
        row[0], row[1] = span

    def _rebuild_sms(self) -> None:
        """The SyncManagers after the PDI locked or released some (0x0807 bit 0; one it locks
        protects its whole area, datasheet I 8.7): what the commit does after a frame wrote
        SyncManager registers (:func:`_syncmanagers`), at this ESC alone, with the activate
        bytes as they are (the PDI toggled none) and no mailbox handler to run for it."""
        mem = self.mem
        activate = bytes(mem[REG_SM + 6 : REG_SM + SM_BYTES * self.config.syncmanagers : SM_BYTES])
        events = bytes(mem[REG_ECAT_EVENT : REG_ECAT_EVENT + 2])
        enabled = np.frombuffer(activate, np.uint8).reshape(1, -1)
        _syncmanagers([self], self._rows[0], self._rows[1], [0], enabled, frame=False)
        if bytes(mem[REG_ECAT_EVENT : REG_ECAT_EVENT + 2]) != events:  # an SM interrupt went
            self.update_irq()

    def _change_syncmanagers(self, change: SmChange, decoded: SmTable) -> None:
        """The SyncManagers after their table changed to ``decoded`` (:func:`sm_change`): the ones
        that start anew lose their state, the others keep it (their status registers are the
        caller's: :func:`_syncmanagers`, over the rows of the ESCs a commit changes).

        The SyncManagers are changed once first needed (:meth:`_make_sms`), after all the
        changes since they last were: one that started anew in any of them is new, one kept
        in all of them keeps its state. Hostile frames change the tables of every ESC often,
        and changing them at each of 160 ESCs took up to 1.5 ms a frame."""
        self._change_sms(change, decoded, frozenset([entry.number for entry in change.fresh]))

    @staticmethod
    def _change_syncmanagers_together(
        devices: Iterable[EscDevice], change: SmChange, decoded: SmTable
    ) -> None:
        """:meth:`_change_syncmanagers` at each of ``devices``, and their mailbox handlers due
        (one change, as the chain's commit over the rows finds it)."""
        fresh = frozenset([entry.number for entry in change.fresh])
        for dev in devices:
            dev._change_sms(change, decoded, fresh)
            dev._mailbox_due = True

    def _change_sms(self, change: SmChange, decoded: SmTable, fresh: frozenset[int]) -> None:
        """:meth:`_change_syncmanagers`, ``fresh`` the indices of those the change starts anew."""
        self._forget_lrd_plans()
        self.sm_areas = decoded
        unmade = self._unmade
        if not change.kept or (unmade is not None and unmade.fresh is None):  # all start anew
            self._unmade = _Unmade(None, decoded, change.by_start)
            return
        if unmade is not None and unmade.fresh is not None:  # those of the changes before too
            fresh |= unmade.fresh
        self._unmade = _Unmade(fresh, decoded, change.by_start)

    def _make_sms(self) -> None:
        """Change the SyncManagers as :attr:`_unmade` says (:meth:`_change_syncmanagers`),
        before anything reads or changes them: those of the decoded table that start anew are
        new, the others keep their state and take their PDI lock from it, and those it leaves
        out have no buffer."""
        unmade = self._unmade
        assert unmade is not None
        fresh, decoded, by_start = unmade.fresh, unmade.decoded, unmade.by_start
        self._unmade = None
        sms = self._sms
        made = self._as_new(decoded)
        if fresh is not None:  # the others keep their state
            for y, _, _, _, locked in decoded:
                if y in fresh:
                    continue
                held = sms[y]
                if held is None:  # reset by the PDI just before (pdi_deactivate_sms)
                    self.mem[REG_SM + SM_BYTES * y + 5] = SM_NO_BUFFER
                    self._sm_event(y)
                elif not held.shared:  # (a shared one is as new: the entry's own now)
                    held.locked = locked != 0
                    made[y] = held
        sms[:] = made
        self._active = [sms[y] for y in by_start]  # type: ignore[misc]  # each set above

    def _as_new(self, decoded: SmTable) -> list[SmRun | None]:
        """The SyncManagers of the decoded table ``decoded`` as new, by index (None where
        none), in a list of the ESC's own: objects shared by every ESC that makes them
        (:attr:`emulator.esc.mapping.Caches.as_new`), each until the ESC changes its state
        (:meth:`_own`); making them at 160 ESCs had taken up to 600 us in a frame."""
        key = (decoded, len(self._sms))
        cache = self._caches.as_new
        found: list[SmRun | None] | None = cache.get(key)
        if found is None:
            found = [None] * len(self._sms)
            for y, start, length, control, locked in decoded:
                found[y] = SmRun(y, start, length, control, locked != 0, shared=True)
            remember(cache, key, found)
        return list(found)

    def _own(self, sm: SmRun) -> SmRun:
        """``sm``, or where it is shared (:meth:`_as_new`) a copy of the ESC's own in its
        place: what every change of a SyncManager's state goes through."""
        if not sm.shared:
            return sm
        mine = SmRun(sm.index, sm.start, sm.length, sm.control, sm.locked)
        self._sms[sm.index] = mine
        active = self._active
        active[active.index(sm)] = mine
        return mine

    @staticmethod
    def _sm_registers_written_together(devices: Iterable[EscDevice]) -> None:
        """After a frame changed SyncManager registers: the mailbox handler of each of ``devices``
        runs at its end (:meth:`_finish_frame`; a repeat request, datasheet II 2.14.7)."""
        for dev in devices:
            dev._mailbox_due = True

    def set_port1_link(self, link: bool) -> None:
        """The chain connects (or disconnects) a neighbour at port 1: DL status 0x0110 anew
        (:func:`_dl_status`, which also caches what the chain asks for every frame, the port 1
        forwarding decision and whether the source MAC is marked)."""
        self.port1_link = link
        _dl_status([self], self._rows[0], self._rows[1])
        self.update_irq()

    def _sm_event(self, index: int) -> None:
        """ECAT event request 0x0210 bits 4-11 mirror SyncManager 0-7's interrupt for ECAT
        where its control bit 4 enables it (datasheet II 0x0210, 0x0804): a buffer the PDI
        wrote and ECAT has not opened (status bit 0, ECAT reads it), or read and ECAT has not
        written again (bit 1, ECAT writes it)."""
        if index >= 8:
            return
        mem = self.mem
        at = REG_SM + SM_BYTES * index
        pending = ecat_interrupt_pending(mem[at + 4], mem[at + 5])
        byte, bit = REG_ECAT_EVENT + (4 + index) // 8, 1 << ((4 + index) % 8)
        old = mem[byte]
        new = old | bit if pending else old & ~bit
        if new != old:
            mem[byte] = new
            self.update_irq()

    def _clear_event(self, bits: int) -> None:
        if self.mem[REG_ECAT_EVENT] & bits:
            self.mem[REG_ECAT_EVENT] &= ~bits
            self.update_irq()

    def update_irq(self) -> None:
        """The ECAT event request 0x0210 under the mask 0x0200 (datasheet I Table 3), kept in
        :attr:`irq` for the IRQ field of every datagram: :func:`_event_requests` of this ESC;
        while it reacts among others (:func:`react_together`), of all of them afterwards."""
        if self._irq_batch is not None:
            self._irq_batch.append(self)
        else:
            _event_requests([self], self._rows[0], self._rows[1])

    def count_frame_error(self) -> None:
        """A malformed frame: the ECAT processing unit error counter 0x030C counts it."""
        self.count_error(REG_PU_ERRORS)

    def count_error(self, register: int, times: int = 1) -> None:
        """An 8-bit error counter in 0x0300-0x0313 counts ``times`` (saturating at 0xFF):
        invalid frames 0x0300 + 2 x port, forwarded errors 0x0308 + port, lost links
        0x0310 + port (datasheet II 2.6)."""
        if not ERROR_COUNTERS[0] <= register < ERROR_COUNTERS[1]:
            raise TopologyError(f"{register:#06x} is not an ESC error counter")
        self.mem[register] = min(0xFF, self.mem[register] + times)


TOGETHER_MIN: Final = 4  # ESCs with equal writes from which one pass over rows beats one by one
_Rows = npt.NDArray[np.intp]


class _Slot:
    """One register write of a frame at several ESCs (:func:`_commit_slots`; a class, made as
    a native object, like :class:`_Unmade`)."""

    __slots__ = ("addr", "data", "members", "n")

    def __init__(
        self, addr: int, n: int, members: list[int] | None, data: npt.NDArray[np.uint8]
    ) -> None:
        self.addr = addr
        self.n = n  # bytes
        self.members = members  # the ESCs (indices) that made it; None: every one
        self.data = data  # one row for all, or a row per member (per ESC when None)


def commit_together(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    *,
    alike: bool = True,
) -> None:
    """Commit the pending register writes of ``devices`` (one configuration), whose memory is
    ``memory[rows]``, as each one's :meth:`EscDevice.end_frame` would (before
    :meth:`EscDevice._finish_frame`): equal lists, or with ``alike`` False lists of writes at the
    same addresses and lengths whose bytes differ from ESC to ESC (a logical datagram's through
    FMMUs that map each ESC's own frame bytes onto registers), each write then a row of bytes
    per ESC."""
    first = devices[0].pending
    slots: list[_Slot] = []
    for j, (addr, written) in enumerate(first):
        if alike:
            data = np.frombuffer(written, np.uint8)
        else:
            blob = b"".join([dev.pending[j][1] for dev in devices])
            data = np.frombuffer(blob, np.uint8).reshape(len(devices), len(written))
        slots.append(_Slot(addr, len(written), None, data))
    _commit_slots(devices, memory, rows, slots)


def commit_apart(devices: Sequence[EscDevice], memory: npt.NDArray[np.uint8], rows: _Rows) -> bool:
    """:func:`commit_together` of ``devices`` (one configuration) whose lists of writes differ
    in their addresses and lengths too (a logical datagram's through FMMUs that differ from ESC
    to ESC): each write at the ESCs that made it, in an order that keeps every ESC's own (the
    ESCs' writes are independent of each other's). False, having done nothing, where no such
    order exists (two ESCs made two writes in opposite orders): then each ESC commits alone."""
    index: dict[tuple[int, int, int], int] = {}  # (address, length, repeat) -> write
    members: list[list[int]] = []
    blobs: list[list[bytes]] = []
    after: list[set[int]] = []  # the writes some ESC made after each
    for i, dev in enumerate(devices):
        repeats: dict[tuple[int, int], int] = {}
        last = -1
        for addr, written in dev.pending:
            shape = (addr, len(written))
            k = repeats.get(shape, 0)
            repeats[shape] = k + 1
            key = (addr, len(written), k)
            j = index.get(key)
            if j is None:
                j = index[key] = len(members)
                members.append([])
                blobs.append([])
                after.append(set())
            members[j].append(i)
            blobs[j].append(written)
            if last >= 0:
                after[last].add(j)
            last = j
    order = _ordered(after)
    if order is None:
        return False
    keys = list(index)
    slots = []
    for j in order:
        addr, n, _ = keys[j]
        data = np.frombuffer(b"".join(blobs[j]), np.uint8).reshape(len(members[j]), n)
        slots.append(_Slot(addr, n, None if len(members[j]) == len(devices) else members[j], data))
    _commit_slots(devices, memory, rows, slots)
    return True


def _ordered(after: list[set[int]]) -> list[int] | None:
    """The writes 0..len(after)-1 in an order where each comes before those ``after`` it names
    (a topological order, :mod:`graphlib`), or None where there is none (a cycle)."""
    sorter: TopologicalSorter[int] = TopologicalSorter(dict.fromkeys(range(len(after)), ()))
    for j, later in enumerate(after):
        for k in later:
            sorter.add(k, j)
    try:
        return list(sorter.static_order())
    except CycleError:
        return None


def _commit_slots(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    slots: Sequence[_Slot],
) -> None:
    """The commit of :func:`commit_together` and :func:`commit_apart`: each write of ``slots``
    in order, at the ESCs that made it, through the write plans (masked, or the registers with
    side effects, :func:`write_special`); then what the writes set off, step by step over the
    ESCs (each only where its own writes set it off, or where doing it again changes
    nothing)."""
    plans = devices[0].write_plans
    masks = plans.mask_array
    for dev in devices:
        dev.pending.clear()
    pending = [plans.plan(slot.addr, slot.n) for slot in slots]
    touched = 0
    for _, touches in pending:
        touched |= touches
    every = consecutive(rows)
    sm_before = memory[every, REG_SM : plans.sm_end].copy() if touched & TOUCHES_SM else None
    fmmu_before = (
        memory[every, REG_FMMU : plans.fmmu_end].copy() if touched & TOUCHES_FMMU else None
    )
    enabled = sm_before[:, 6::SM_BYTES] if sm_before is not None else None  # bit 0
    flags = [False] * 5  # (unused), EEPROM command, DL control, FMMU, SM written
    eeprom = np.zeros(len(rows), np.bool_)
    al = np.zeros(len(rows), np.bool_)  # AL control written (taken: not a full mailbox)
    dc: tuple[int, int] | None = None  # the DC registers every ESC wrote
    dc_of: dict[int, tuple[int, int]] = {}  # and those only some did, by ESC
    for slot, (segments, _) in zip(slots, pending, strict=True):
        addr, idx = slot.addr, slot.members
        if idx is None:
            who, at, at_rows, on = devices, every, rows, enabled
            written_ee, written_al = eeprom, al
        else:
            who, at = [devices[i] for i in idx], rows[idx]
            at_rows, on = at, None if enabled is None else enabled[idx]
            written_ee, written_al = np.zeros(len(idx), np.bool_), np.zeros(len(idx), np.bool_)
        for lo, hi, mask, marks in segments:
            part = slot.data[..., lo - addr : hi - addr]  # one row, or one per ESC
            if mask < 0:  # a register with side effects
                write_special(
                    who, memory, at_rows, lo, hi, part, on, masks, flags, written_ee, written_al
                )
            elif mask:
                write_masked(memory, at, lo, hi, part, masks[lo:hi])
                if marks:
                    if idx is None:
                        dc = mark(lo, hi, flags, plans.fmmu_end, dc)
                    else:
                        for i in idx:
                            found = mark(lo, hi, flags, plans.fmmu_end, dc_of.get(i))
                            if found is not None:
                                dc_of[i] = found
        if idx is not None:
            eeprom[idx] |= written_ee
            al[idx] |= written_al
    _, _, dl, fmmu, sm = flags
    # what the writes set off, in this order (datasheet I 3.4), step by step over all the ESCs:
    # FMMU and SyncManager tables, DL control, DC registers, an EEPROM command, AL control
    if fmmu and fmmu_before is not None:  # changed FMMU tables
        changed = (memory[every, REG_FMMU : plans.fmmu_end] != fmmu_before).any(axis=1)
        _fmmus(devices, memory, rows, changed.nonzero()[0].tolist(), plans.fmmu_end)
    if sm and sm_before is not None and enabled is not None:  # changed SyncManager tables
        changed = (memory[every, REG_SM : plans.sm_end] != sm_before).any(axis=1)
        _syncmanagers(devices, memory, rows, changed.nonzero()[0].tolist(), enabled)
    if dl:
        _dl_status(devices, memory, rows)  # (the same again where DL control stayed)
    if dc is not None and not dc_of:
        configure_together([dev.dc for dev in devices], memory, rows, *dc)
    elif dc is not None or dc_of:  # each ESC the DC registers it wrote, alike ones together
        by_range: dict[tuple[int, int], list[int]] = {}
        for i in range(len(devices)):
            own = dc_of.get(i)
            if own is not None and dc is not None:
                own = (min(own[0], dc[0]), max(own[1], dc[1]))
            elif own is None:
                own = dc
            if own is not None:
                by_range.setdefault(own, []).append(i)
        for (lo, hi), at_ in by_range.items():
            clocks = [devices[i].dc for i in at_]
            configure_together(clocks, memory, rows[np.array(at_, np.intp)], lo, hi)
    _event_requests(devices, memory, every)
    # (the rows' positions at once: a mask's any() runs through a Python frame of numpy's)
    which = eeprom.nonzero()[0]
    if len(which):
        _eeprom_commands(devices, memory, rows, which)
    which = al.nonzero()[0]
    if len(which):  # AL control, a mailbox the PDI empties by reading it (II 0x0120)
        EscDevice._hold(control_written(devices, memory, rows, which))


def consecutive(rows: _Rows | slice) -> _Rows | slice:
    """``rows`` (ascending, distinct), or the slice of them where they are consecutive: views
    of the memory instead of copies, assignments without fancy indexing (a few us less each);
    a slice as it is."""
    if isinstance(rows, slice):
        return rows
    if len(rows) and rows[-1] - rows[0] == len(rows) - 1:
        return slice(int(rows[0]), int(rows[-1]) + 1)
    return rows


def _eeprom_commands(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: npt.NDArray[np.intp],
) -> None:
    """The commands ECAT wrote to 0x0502 at ``devices[i]`` for ``i`` in ``which``
    (:func:`emulator.esc.eeprom.execute_commands`, each with its EEPROM); where one reloaded
    configuration area A, PDI operational follows the load (datasheet I 11.2.1) and with it DL
    status, and a PDI that came up starts its firmware."""
    at = rows[which]
    chosen = which.tolist()
    reload, good = execute_commands([devices[i].sii for i in chosen], memory, at)
    if not good:
        return
    again = [devices[i] for i in which[reload].tolist()]
    running = [dev.pdi_operational for dev in again]
    for dev, loaded in zip(again, good, strict=True):
        dev.pdi_operational = loaded
    _dl_status(again, memory, at[reload])
    for dev, before in zip(again, running, strict=True):
        if dev.pdi_operational and not before:  # the PDI came up: the firmware starts
            dev.al_control_full = False  # and reads AL control (II 0x0120)
            dev.app.power_on(dev)
    _event_requests(again, memory, at[reload])


def power_on_together(devices: Sequence[EscDevice]) -> None:
    """Power on ``devices`` (at power-on, or an ESC reset, datasheet II 0x0040): the reset values
    of section II and then the EEPROM load of datasheet I 11.1, over the rows of each line's
    memory; then each one's application starts where the load made the PDI operational."""
    lines: dict[int, tuple[npt.NDArray[np.uint8], list[EscDevice]]] = {}
    for dev in devices:
        lines.setdefault(id(dev._rows[0]), (dev._rows[0], []))[1].append(dev)
    for memory, members in lines.values():
        rows = np.concatenate([dev._rows[1] for dev in members])
        every = consecutive(rows) if len(rows) > 1 else rows
        memory[every] = 0
        configs: dict[EscConfig, list[int]] = {}
        for k, dev in enumerate(members):
            configs.setdefault(dev.config, []).append(k)
        for cfg, ks in configs.items():
            at = rows[ks]
            identity = struct.pack(
                "<BBHBBBBH",
                cfg.esc_type,
                cfg.revision,
                cfg.build,
                cfg.fmmus,
                cfg.syncmanagers,
                cfg.ram_kib,
                cfg.port_descriptor,
                cfg.features,
            )
            memory[at, REG_TYPE : REG_TYPE + len(identity)] = np.frombuffer(identity, np.uint8)
            memory[at, REG_SM + 5 : REG_SM + SM_BYTES * cfg.syncmanagers : SM_BYTES] = SM_NO_BUFFER
        for addr, value in _RESET_VALUES:
            memory[every, addr : addr + len(value)] = np.frombuffer(value, np.uint8)
        power_on_interface([dev.sii for dev in members], memory, rows)
        for dev in members:
            dev._reset_state()
        registers_power_on(memory, every)
        load_config_areas(members, memory, rows, first=True)
        memory[every, REG_ECAT_EVENT] |= EVENT_DL_STATUS  # the links came up
        _dl_status(members, memory, rows)
        for dev in members:
            if dev.pdi_operational:
                dev.app.power_on(dev)
        _event_requests(members, memory, every)


# the reset values of section II besides identity, EEPROM and SyncManager status: DL control
# (loop ports auto, forwarding of non-EtherCAT frames, RX FIFO), AL control and status INIT,
# watchdog divider (100 us ticks), PDI and process data watchdogs (100 ms), watchdog status
_RESET_VALUES: Final = (
    (REG_DL_CONTROL, bytes((0x01, 0x00, 0x07, 0x00))),
    (REG_AL_CONTROL, struct.pack("<H", 0x0001)),
    (REG_AL_STATUS, struct.pack("<H", 0x0001)),
    (REG_WD_DIVIDER, struct.pack("<H", 0x09C2)),
    (REG_WD_PDI, struct.pack("<H", 0x03E8)),
    (REG_WD_PD, struct.pack("<H", 0x03E8)),
    (REG_WD_STATUS, b"\x01"),
)


def load_config_areas(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    *,
    first: bool,
) -> None:
    """Load ESC configuration area A into the registers of ``devices``, whose memory is
    ``memory[rows]``, each from its own EEPROM (:func:`emulator.esc.eeprom.load_config_areas`):
    "PDI operational" (DL status bit 0, access to process RAM, datasheet I 11.2.1) follows the
    load, a good one bringing it back and a bad one taking it away."""
    loaded = _load([dev.sii for dev in devices], memory, rows, first=first)
    for dev, good in zip(devices, loaded, strict=True):
        dev.pdi_operational = good


_EVENT_WORD: Final = (REG_ECAT_EVENT - REG_ECAT_EVENT_MASK) // 2  # (0x0210 - 0x0200) / 2


def _event_requests(
    devices: Sequence[EscDevice], memory: npt.NDArray[np.uint8], rows: _Rows | slice
) -> None:
    """Each ESC's event request to the master, 0x0210 under the mask 0x0200 (datasheet I
    Table 3), into its :attr:`EscDevice.irq` for the IRQ field of every datagram; of fewer
    than :data:`TOGETHER_MIN` ESCs (one, after a read of AL status clears its event, or the
    PDI's change) from each one's bytes, the arrays' 2.7 us saved."""
    irqs: list[int]
    if len(devices) < TOGETHER_MIN:
        irqs = []
        for dev in devices:
            mem = dev.mem
            mask = mem[REG_ECAT_EVENT_MASK] | mem[REG_ECAT_EVENT_MASK + 1] << 8
            irqs.append(mask & (mem[REG_ECAT_EVENT] | mem[REG_ECAT_EVENT + 1] << 8))
    else:
        # the words from the mask to the request, little-endian (one slice: 0x0200 and 0x0210
        # are 8 words apart)
        words = memory[rows, REG_ECAT_EVENT_MASK : REG_ECAT_EVENT + 2].view("<u2")
        irqs = (words[:, _EVENT_WORD] & words[:, 0]).tolist()
    for dev, irq in zip(devices, irqs, strict=True):
        if dev.irq != irq:
            dev.irq = irq
            dev._caches.events += 1


def react_together(work: Sequence[tuple[EscDevice, int]], memory: npt.NDArray[np.uint8]) -> None:
    """Each ESC of ``work`` (of one line, whose memory is ``memory``) reacts to its event
    (:meth:`EscDevice._reaction`), in order; the event requests the reactions change (AL status,
    SyncManager events) are brought up to date once all reacted, over the rows of those whose
    request changed: no frame reads them meanwhile."""
    changed: list[EscDevice] = []
    try:
        for dev, _ in work:
            dev._irq_batch = changed
        for dev, what in work:
            dev._reaction(what)
    finally:
        for dev, _ in work:
            dev._irq_batch = None
        if changed:
            unique = list({id(dev): dev for dev in changed}.values())
            rows = np.fromiter((dev._rows[1][0] for dev in unique), np.intp, len(unique))
            _event_requests(unique, memory, rows)


def read_buffers(
    devices: list[EscDevice],
    sms: list[SmRun],
    base: int,
    ats: list[int],
    memory: npt.NDArray[np.uint8],
    rows: _Rows | slice,
    buf: bytearray,
) -> bool:
    """ECAT reads whole buffers of read SyncManagers, each access opening and completing one
    (datasheet I 8.1; what :meth:`EscDevice._sm_read` does for such an access): at each of
    ``devices``, whose memory is ``memory[rows]``, its SyncManager of ``sms`` into ``buf`` at
    ``base`` plus its offset of ``ats``. The SyncManagers have one index, start and length;
    the offsets ascend, the buffers apart (a later ESC's read of the same bytes is another
    call). The bytes are the buffer the PDI completed last (:meth:`EscDevice.pdi_write`),
    taken from the rows at once. The buffers change at the end of the frame, the caller's
    :func:`finish_reads` of them. Whether an ESC's event request changed (a SyncManager's
    interrupt for ECAT, control bit 4)."""
    sm = sms[0]
    start, length, st = sm.start, sm.length, REG_SM + SM_BYTES * sm.index + 5
    at = consecutive(rows)
    first = base + ats[0]
    if ats[-1] - ats[0] == (len(ats) - 1) * length:  # one after the other: one copy
        buf[first : first + len(ats) * length] = memory[at, start : start + length].tobytes()
    else:
        to = np.add.outer(np.array(ats, np.intp) + base, np.arange(length, dtype=np.intp))
        np.frombuffer(buf, np.uint8)[to] = memory[at, start : start + length]
    through(memory, at, st, ECAT_OPENED_READ)
    changed = False
    for k in range(len(sms)):  # (indices: mypyc's loop over a list, not an iterator's)
        sm = sms[k]
        sm.open = sm.complete = True
        sm.buf = None  # the bytes in memory, which no frame changes before the buffer changes
        if sm.ecat_interrupt:
            dev = devices[k]
            before = dev.irq
            dev._sm_event(sm.index)
            changed = changed or dev.irq != before
    return changed


def pdi_write_rows(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows | slice,
    addr: int,
    data: npt.NDArray[np.uint8],
) -> None:
    """The PDI of each of ``devices``, whose memory is ``memory[rows]``, writes its row of
    ``data`` at ``addr``: :meth:`EscDevice.pdi_write` at each, the bytes of all written at once
    (a line of patches publishing a sample, :meth:`emulator.esc.chain.EcatChain.publish`)."""
    n = data.shape[1]
    memory[consecutive(rows), addr : addr + n] = data
    for k in range(len(devices)):
        devices[k]._pdi_wrote(addr, n)


def finish_reads(
    devices: list[EscDevice], sms: list[SmRun], memory: npt.NDArray[np.uint8], rows: _Rows | slice
) -> None:
    """Buffer exchange of read SyncManagers after the frame that completed their buffers
    (datasheet I 8.1): at each of ``devices``, whose memory is ``memory[rows]``, its
    SyncManager of ``sms`` (one index for all) unless the frame started it anew
    (:meth:`EscDevice._still`): the buffer is free for the PDI (status bit 0 cleared, its
    read interrupt set), a mailbox empty. After the frame's register writes took effect; a
    second exchange of one buffer in a frame changes nothing more."""
    gone: list[int] = []  # those started anew
    for k in range(len(sms)):
        sm, dev = sms[k], devices[k]
        sm.complete = False
        if not dev._still(sm):
            gone.append(k)
            continue
        sm.open = False
        sm.buf = None  # (the interrupt for ECAT, 0x0210, is as it was: _sm_event)
        if sm.mailbox:
            dev._mailbox_due = True
            sm.full = False
    if len(gone) == len(sms):
        return
    if gone:
        rows = np.delete(np.arange(memory.shape[0])[rows], gone)
    at = consecutive(rows)
    st = REG_SM + SM_BYTES * sms[0].index + 5
    through(memory, at, st, ECAT_EMPTIED if sms[0].mailbox else ECAT_READ)


def finish_together(devices: list[EscDevice], memory: npt.NDArray[np.uint8], rows: _Rows) -> None:
    """:meth:`EscDevice._finish_frame` of ``devices``, whose memory is ``memory[rows]``, after
    :func:`commit_together`: 0x0040 shows no reset under way at every row, and the ESCs with
    more to finish (:meth:`EscDevice._unfinished`) finish the frame (:meth:`EscDevice._finish_frames`)."""
    memory[consecutive(rows), REG_RESET_ECAT] = 0
    EscDevice._finish_frames(EscDevice._unfinished(devices))


def _fmmus(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: Sequence[int],
    end: int,
) -> None:
    """The FMMUs of ``devices[i]`` for ``i`` in ``which`` after a frame changed their registers
    [0x0600, ``end``): each table decoded once per distinct bytes (:func:`fmmu_table`), as
    the commit does after the writes."""
    if not which:
        return
    width = end - REG_FMMU
    tables = memory[rows[list(which)], REG_FMMU:end].tobytes()
    caches = devices[0]._caches  # (the ESCs of one chain)
    for k, i in enumerate(which):
        devices[i]._use_fmmus(fmmu_table(caches, tables[k * width : (k + 1) * width]))


def _syncmanagers(
    devices: Sequence[EscDevice],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: Sequence[int],
    enabled: npt.NDArray[np.uint8],
    *,
    frame: bool = True,
) -> None:
    """What a commit does first to the ESCs ``devices[i]`` for ``i`` in
    ``which`` after a frame changed their SyncManager registers (the rest of it, which an FMMU,
    DC, EEPROM or AL control write sets off, does not touch the SyncManagers, and follows):
    their tables decoded and the changes worked out (:func:`sm_table`, :func:`sm_change`) once
    per distinct table before, table after and activate bytes before the frame (``enabled``, a
    row each), each change's status registers set over the rows at once, and each ESC's
    SyncManagers changed as the change says (:meth:`EscDevice._change_syncmanagers_together`); the
    mailbox handler runs once the frame has passed (not without a ``frame``: the PDI changed
    them, :meth:`EscDevice._rebuild_sms`). An ESC whose table and activate bytes equal
    those of the ESC before it (compared over the rows), with the same table before, joins its
    group without a key of its own."""
    if not which:
        return
    count = enabled.shape[1]
    width = SM_BYTES * count
    groups: dict[tuple[int, bytes], list[int]] = {}
    if len(which) == 1:  # (the PDI's, and many a frame's: nothing to compare)
        i = which[0]
        key = bytes(devices[i].mem[REG_SM : REG_SM + width]) + enabled[i].tobytes()
        groups[0, key] = [i]
    else:
        at = list(which)
        block = np.concatenate((memory[rows[at], REG_SM : REG_SM + width], enabled[at]), axis=1)
        differs = np.ones(len(at), np.bool_)
        differs[1:] = (block[1:] != block[:-1]).any(axis=1)
        held = [devices[i].sm_areas for i in at]
        starts = [  # where a run of ESCs with equal bytes and the same table before starts
            k
            for k, (new, mine, last) in enumerate(
                zip(differs.tolist(), held, [None, *held[:-1]], strict=True)
            )
            if new or mine is not last
        ]
        stride = width + count
        data = block.tobytes()
        for k, end in zip(starts, [*starts[1:], len(at)], strict=True):
            key = data[k * stride : (k + 1) * stride]
            groups.setdefault((id(held[k]), key), []).extend(at[k:end])
    caches = devices[0]._caches  # (the ESCs of one chain)
    for (_, key), members in groups.items():
        table, before = key[:width], key[width:]
        areas = devices[members[0]].sm_areas  # the same object at each of them
        found = sm_table(caches, table)
        if found.entries != areas:
            change = sm_change(caches, areas, before, found)
            if change.no_buffer:  # no buffer, and no interrupt for ECAT (0x0210 bits 4-11)
                no_buffer = change.no_buffer
                bits = [b for b in (4 + (st - REG_SM) // SM_BYTES for st in no_buffer) if b < 12]
                if len(members) < TOGETHER_MIN:  # (written at once over the rows below)
                    for i in members:
                        mem = devices[i].mem
                        for st in no_buffer:
                            mem[st] = SM_NO_BUFFER
                        for bit in bits:
                            mem[REG_ECAT_EVENT + bit // 8] &= ~(1 << bit % 8) & 0xFF
                else:
                    memory[rows[members][:, None], np.array(no_buffer, np.intp)] = SM_NO_BUFFER
                    for bit in bits:
                        memory[rows[members], REG_ECAT_EVENT + bit // 8] &= ~(1 << bit % 8) & 0xFF
            if frame:
                EscDevice._change_syncmanagers_together(
                    [devices[i] for i in members], change, found.entries
                )
            else:
                for i in members:
                    devices[i]._change_syncmanagers(change, found.entries)
        elif frame:
            EscDevice._sm_registers_written_together([devices[i] for i in members])


def _dl_status(devices: Sequence[EscDevice], memory: npt.NDArray[np.uint8], rows: _Rows) -> None:
    """DL status 0x0110 of ``devices``, whose memory is ``memory[rows]`` (:func:`dl_status`,
    with each one's port 1 link and PDI), and each one's forwarding and source MAC marking,
    which the chain asks for every frame."""
    links = [dev.port1_link for dev in devices]
    pdi = [dev.pdi_operational for dev in devices]
    onwards, marks = dl_status(memory, rows, links, pdi)
    for dev, onward, mac in zip(devices, onwards, marks, strict=True):
        dev.onward, dev.sets_mac = onward, mac
        dev._caches.links += 1
