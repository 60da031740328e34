"""The slave behind the ESC: what a real slave's EEPROM and firmware hold, behind the PDI of
:mod:`emulator.esc.pdi` (issue 39: the ESC and its firmware meet at that one interface).

:mod:`.sii` (:class:`~.sii.SlaveInfo`, what a slave puts into its SII EEPROM), :mod:`.state_machine`
(the AL state machine the firmware runs: the PDI application, the firmware any slave shares and the
skin patch's). A patch with a mailbox adds :mod:`.mailbox` (SM0/SM1, counter, repeat request),
:mod:`.coe` (SDO, SDO information, emergencies) and :mod:`.objects` (its object dictionary). A
slave an ESI file describes is a second application behind the same ESC: :mod:`.esi_slave` (the
application, its SII image), :mod:`.esi_objects` (the ESI's dictionary, PDO assignment and mapping)
and :mod:`.esi_inputs` (input values from a file).

This file imports nothing, so that importing one module does not load the others.
"""
