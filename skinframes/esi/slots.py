"""Modular devices (ETG.2000 ``Slots``; ETG.5001 Modular Device Profile): modules in slots.

:func:`configure_slots` puts the modules a user names in the slots of a device of the file and
returns the device as configured: the modules' PDOs and objects joined to the device's, moved
by their slot's increments where they ``DependOnSlot``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from skinframes.errors import EsiFormatError
from skinframes.esi.model import (
    EsiDevice,
    EsiDictionary,
    EsiFile,
    EsiModule,
    EsiPdo,
    EsiSlot,
    _number_or_none,
)


def configure_slots(esi: EsiFile, device: EsiDevice, selectors: Sequence[str]) -> EsiDevice:
    """``device`` with modules in its slots: the modules ``selectors`` name (a ModuleIdent in
    decimal, ``0x`` or ``#x`` hex, or a Type text), the k-th in slot number k (from 0).

    The modules fill the slots in order (ETG.2000 Slots, ETG.5001 Modular Device Profile): each
    slot takes modules it names (ModuleIdent or ModuleClass) up to its MaxInstances, and must
    have its MinInstances (and there may be MaxSlotCount modules at most, unless it is 0).
    Module k's PDOs and objects join the device's, an ``Index`` or ``Exclude`` with
    ``DependOnSlot`` moved by k times the slot's SlotPdoIncrement (a PDO's) or
    SlotIndexIncrement (an entry's or object's; the slot's own where it gives one, else the
    Slots'); one with the index of a device's own takes its place (ETG.2000
    ``OverwrittenByModule``; vendors list the default modules' PDOs in the device too);
    ``configured_modules`` holds their idents.

    Raises:
        EsiFormatError: the device has no slots, a selector names no module its slots may hold,
            the modules do not fit the slots, or two modules have a PDO or object of one index.
    """
    where = f"ESI device {device.type_name} (line {device.line})"
    if device.slots is None:
        raise EsiFormatError(f"{where}: has no <Slots>, so no modules")
    holdable = esi.slot_modules(device)
    modules = [_module_named(holdable, s, where) for s in selectors]
    slots = device.slots.slots
    placed: list[EsiSlot] = []
    at, count = 0, 0
    for k, m in enumerate(modules):
        while at < len(slots) and (count >= slots[at].max_instances or not _takes(slots[at], m)):
            _enough(slots[at], count, where)
            at, count = at + 1, 0
        if at == len(slots):
            raise EsiFormatError(
                f"{where}: module {k + 1} ({m.type_name}): no slot after the ones before takes it"
            )
        placed.append(slots[at])
        count += 1
    for slot in slots[at:]:
        _enough(slot, count if slot is slots[at] else 0, where)
    limit = device.slots.max_slot_count
    if limit and len(modules) > limit:  # 0, as some vendors write it: no limit given
        raise EsiFormatError(f"{where}: {len(modules)} modules, MaxSlotCount is {limit}")
    pdos: dict[int, tuple[bool, EsiPdo, str]] = {p.index: (True, p, "") for p in device.rx_pdos}
    pdos |= {p.index: (False, p, "") for p in device.tx_pdos}
    types = list(device.dictionary.data_types) if device.dictionary else []
    objects = {o.index: (o, "") for o in device.dictionary.objects} if device.dictionary else {}
    for k, (m, slot) in enumerate(zip(modules, placed, strict=True)):
        pdo_step = k * _increment(slot.slot_pdo_increment, device.slots.slot_pdo_increment)
        index_step = k * _increment(slot.slot_index_increment, device.slots.slot_index_increment)
        mine = f"module {k + 1} ({m.type_name}, line {m.line})"
        for rx, theirs in ((True, m.rx_pdos), (False, m.tx_pdos)):
            for p in theirs:
                moved = _moved_pdo(p, pdo_step, index_step)
                other = pdos.get(moved.index, (rx, p, ""))[2]
                if other:
                    raise EsiFormatError(f"{where}: {mine}: PDO {moved.index:#06x} is {other}'s")
                pdos[moved.index] = (rx, moved, mine)
        if m.dictionary is None:
            continue
        named = {t.name for t in types}
        types += [t for t in m.dictionary.data_types if t.name not in named]
        for o in m.dictionary.objects:
            index = o.index + (index_step if o.depend_on_slot else 0)
            other = objects.get(index, (o, ""))[1]
            if other:
                raise EsiFormatError(f"{where}: {mine}: object {index:#06x} is {other}'s")
            objects[index] = (dataclasses.replace(o, index=index, depend_on_slot=False), mine)
    dictionary = (
        EsiDictionary(tuple(types), tuple(o for o, _ in objects.values()))
        if device.dictionary is not None or objects
        else None
    )
    return dataclasses.replace(
        device,
        rx_pdos=tuple(p for rx, p, _ in pdos.values() if rx),
        tx_pdos=tuple(p for rx, p, _ in pdos.values() if not rx),
        dictionary=dictionary,
        configured_modules=tuple(m.module_ident for m in modules),
    )


def _module_named(modules: tuple[EsiModule, ...], selector: str, where: str) -> EsiModule:
    """The module whose Type text, else whose ModuleIdent, is ``selector``."""
    found = [m for m in modules if m.type_name == selector]
    if not found:
        ident = _number_or_none(selector)
        found = [m for m in modules if ident is not None and m.module_ident == ident]
    if not found:
        listing = ", ".join(f"{m.type_name} ({m.module_ident:#x})" for m in modules) or "none"
        raise EsiFormatError(
            f"{where}: no module {selector!r} its slots may hold; they may hold: {listing}"
        )
    return found[0]


def _takes(slot: EsiSlot, module: EsiModule) -> bool:
    return module.module_ident in slot.module_idents or module.module_class in slot.module_classes


def _enough(slot: EsiSlot, count: int, where: str) -> None:
    if count < slot.min_instances:
        raise EsiFormatError(
            f"{where}: slot {slot.name!r} (line {slot.line}) needs {slot.min_instances} "
            f"module(s) at least, the modules given put {count} in it"
        )


def _increment(own: int | None, common: int) -> int:
    return common if own is None else own


def _moved_pdo(p: EsiPdo, pdo_step: int, index_step: int) -> EsiPdo:
    """A module's PDO in its slot: ``DependOnSlot`` indices moved (ETG.2000)."""
    entries = tuple(
        dataclasses.replace(e, index=e.index + index_step, depend_on_slot=False)
        if e.depend_on_slot and e.index
        else e
        for e in p.entries
    )
    index = p.index + pdo_step if p.depend_on_slot else p.index
    excludes = tuple(
        x + pdo_step if moves else x
        for x, moves in zip(p.excludes, p.excludes_depend_on_slot, strict=True)
    )
    return dataclasses.replace(
        p,
        index=index,
        entries=entries,
        excludes=excludes,
        depend_on_slot=False,
        excludes_depend_on_slot=(False,) * len(excludes),
    )
