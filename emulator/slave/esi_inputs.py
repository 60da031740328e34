"""Input values from a file for a slave an ESI file describes (``serve ecat --esi-inputs``).

The file is CSV (read with :mod:`csv`): a header naming input entries as ``INDEX:SUBINDEX``
(``0x6000:1``, ``#x6000:1`` or decimal), then one row per publication, one integer per entry
(decimal, ``0x`` or ``#x`` hex; a negative value is its two's complement in the entry's
bits). Blank lines and lines starting with ``#`` (but not ``#x``, a number) are skipped. Publication ``c`` (the ``c``-th time the inputs
change, every ``--period-ms``; 0 before the first) takes row ``c`` modulo the number of rows.
Entries the file does not name keep the counter pattern.

Every named entry must be an entry of one of the device's TxPDOs (its ``BitLen`` is the entry's
width); a value must fit that width (signed or unsigned). Anything else, and a file that is
not UTF-8 text or is larger than :data:`MAX_INPUTS_BYTES`, is a
:class:`~skinframes.errors.DecodeError` naming the file (and the line, where there is one).
"""

from __future__ import annotations

import csv
import dataclasses
import io
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Final

from skinframes.errors import DecodeError
from skinframes.esi import EsiDevice, parse_number

__all__ = ["MAX_INPUTS_BYTES", "EsiInputs", "pack_entries", "read_esi_inputs"]

# a larger file is refused before it is read whole: 4 MiB holds 2 million one-digit rows (read in
# about 6 s into 0.2 GB of tuples), or 170,000 rows of four 16-bit values
MAX_INPUTS_BYTES: Final = 4 << 20


@dataclasses.dataclass(frozen=True, slots=True)
class EsiInputs:
    """The entries a file names, their widths, and its rows of values (unsigned, cut to the
    width); ``source`` names the file."""

    entries: tuple[tuple[int, int], ...]
    bits: tuple[int, ...]
    rows: tuple[tuple[int, ...], ...]
    source: str = ""

    def value(self, index: int, subindex: int, publication: int) -> int | None:
        """The entry's value at ``publication``, or None when the file does not name it."""
        try:
            column = self.entries.index((index, subindex))
        except ValueError:
            return None
        return self.rows[publication % len(self.rows)][column]


def read_esi_inputs(path: str | Path, device: EsiDevice) -> EsiInputs:
    """Read an inputs file for ``device`` (see the module's description).

    Raises:
        DecodeError: the file is empty, too large or not UTF-8 text, names an entry no TxPDO
            of the device has, or holds a line that is not CSV, a row of the wrong length or a
            value that is no number or does not fit its entry.
        OSError: the file cannot be read (missing, a directory, no permission).
    """
    source = str(path)
    text = _text(path, source)
    widths = {(e.index, e.subindex): e.bit_length for p in device.tx_pdos for e in p.entries}
    header: list[tuple[int, int]] | None = None
    bits: list[int] = []
    rows: list[tuple[int, ...]] = []
    for number, cells in _rows(text, source):
        where = f"{source}: line {number}"
        if header is None:
            header = [_entry(cell, where) for cell in cells]
            for entry in header:
                if entry not in widths:
                    raise DecodeError(
                        f"{where}: {entry[0]:#06x}:{entry[1]} is no entry of a TxPDO of "
                        f"{device.type_name}"
                    )
            if len(set(header)) != len(header):
                raise DecodeError(f"{where}: an entry is named twice")
            bits = [widths[e] for e in header]
            continue
        if len(cells) != len(header):
            raise DecodeError(f"{where}: {len(cells)} values, the header names {len(header)}")
        rows.append(tuple(_value(c, b, where) for c, b in zip(cells, bits, strict=True)))
    if header is None or not rows:
        raise DecodeError(f"{source}: no header and rows (INDEX:SUBINDEX,... then values)")
    return EsiInputs(tuple(header), tuple(bits), tuple(rows), source)


def pack_entries(layout: Sequence[tuple[int, int, int]], values: Sequence[int]) -> bytes:
    """The SyncManager buffer whose entries ``layout`` lists ((index, subindex, bits), in
    mapping order) hold ``values`` (one per entry, unsigned, cut to the bits): ETG.1000.6 5.6.7,
    packed bit by bit from bit 0 of the first byte, little-endian; gaps (index 0) stay 0. The
    inverse of :func:`emulator.slave.esi_slave.entry_values`."""
    whole, at = 0, 0
    for (index, _, bits), value in zip(layout, values, strict=True):
        if index:
            whole |= (value & ((1 << bits) - 1)) << at
        at += bits
    return whole.to_bytes((at + 7) // 8, "little")


def _text(path: str | Path, source: str) -> str:
    """The file's text, read as UTF-8 up to :data:`MAX_INPUTS_BYTES`."""
    with open(path, "rb") as file:
        data = file.read(MAX_INPUTS_BYTES + 1)
    if len(data) > MAX_INPUTS_BYTES:
        raise DecodeError(f"{source}: larger than {MAX_INPUTS_BYTES >> 20} MiB")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = len((data[: exc.start].decode("utf-8") + ".").splitlines())  # as _rows counts
        raise DecodeError(
            f"{source}: line {line}: byte {data[exc.start]:#04x} is not UTF-8 text"
        ) from None


def _rows(text: str, source: str) -> Iterator[tuple[int, list[str]]]:
    """(line number, cells) of every line that is not blank or a comment."""
    for number, line in enumerate(text.splitlines(), start=1):
        start = line.lstrip()
        if not start or (start.startswith("#") and start[:2].lower() != "#x"):
            continue
        try:
            (cells,) = csv.reader(io.StringIO(line))
        except csv.Error as exc:  # a cell longer than csv.field_size_limit()
            raise DecodeError(f"{source}: line {number}: not CSV: {exc}") from None
        yield number, [c.strip() for c in cells]


def _entry(cell: str, where: str) -> tuple[int, int]:
    index, sep, sub = cell.partition(":")
    try:
        if not sep:
            raise ValueError(cell)
        return parse_number(index), parse_number(sub)
    except ValueError:
        raise DecodeError(f"{where}: {cell!r} is not INDEX:SUBINDEX (such as 0x6000:1)") from None


def _value(cell: str, bits: int, where: str) -> int:
    try:
        value = parse_number(cell)
    except ValueError:
        raise DecodeError(f"{where}: {cell!r} is not a number") from None
    if not -(1 << (bits - 1)) <= value < (1 << bits):
        raise DecodeError(f"{where}: {value} does not fit {bits} bits")
    return value & ((1 << bits) - 1)
