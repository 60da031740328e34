"""The emulated EtherCAT slave controller (ESC): :mod:`.registers` (the register map),
:mod:`.sii` (the SII EEPROM image), :mod:`.state_machine` (the AL state machine and the PDI
application), :mod:`.device` (one ESC) and :mod:`.chain` (a line of ESCs processing whole frames,
for the live transport and the timing engine alike).

A patch with a mailbox adds :mod:`.mailbox` (SM0/SM1, counter, repeat request), :mod:`.coe`
(SDO, SDO information, emergencies) and :mod:`.objects` (its object dictionary). A slave an ESI
file describes is a second application behind the same ESC: :mod:`.esi_slave` (the application,
its SII image) and :mod:`.esi_objects` (the ESI's dictionary, PDO assignment and mapping).

This file imports nothing but :mod:`.compiled`, so that importing one module does not load the
others; where :mod:`.compiled` built them, the busiest modules are C extensions of the same sources.
"""

from emulator.esc import compiled as _compiled

_found = _compiled.folder()
if _found is not None:  # the busiest modules compiled from these very sources (compiled.py)
    __path__.insert(0, str(_found))
