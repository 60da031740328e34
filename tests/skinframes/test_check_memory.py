"""check keeps its findings as columns (12 bytes a finding), reads them out as FrameFindings, and
writes its JSON one finding at a time: a capture with a finding in every frame costs bytes per
frame, not an object per frame."""

from __future__ import annotations

import io
import json
import struct
from pathlib import Path

import pytest
from memory_util import traced_peak

from skinframes.check import check_file
from skinframes.findings import FindingList, FrameFinding, Severity, error, info, warning

ROOT = Path(__file__).resolve().parents[2]


def empty_frames_pcap(path: Path, records: int) -> Path:
    """A classic pcap of zero-length records: every one is an ``eth.truncated`` error."""
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 0xFFFF, 1)
    path.write_bytes(header + struct.pack("<IIII", 0, 0, 0, 0) * records)
    return path


def test_a_finding_list_is_the_list_it_replaces() -> None:
    a, b, c = error("x.a", "a"), warning("x.b", "b"), info("x.c", "c")
    items = [FrameFinding(5, a), FrameFinding(2, b, 7), FrameFinding(5, a), FrameFinding(-1, c)]
    found = FindingList(items[:2])
    found += items[2:3]
    found.append(items[3])
    assert found == items and list(found) == items and len(found) == 4
    assert found[1] == items[1] and found[-1] == items[-1] and found[1:3] == items[1:3]
    assert found.count_at_least(Severity.WARNING) == 3
    assert list(found.at_least(Severity.ERROR)) == [items[0], items[2]]
    found.sort()  # by record index, stably
    assert found == sorted(items, key=lambda f: f.index)
    found.sort(key=lambda f: f.finding.code)
    assert found == sorted(sorted(items, key=lambda f: f.index), key=lambda f: f.finding.code)
    with pytest.raises(IndexError):
        found[4]


@pytest.mark.parametrize("floor", list(Severity))
def test_the_json_written_one_finding_at_a_time_is_json_dumps(floor: Severity) -> None:
    for path in (
        ROOT / "pcaps" / "ecat_all_commands.pcap",
        ROOT.parent / "shared" / "captures" / "epl-viz_1CN.pcapng",
    ):
        report = check_file(path)
        out = io.StringIO()
        report.write_json(out, floor)
        assert out.getvalue() == json.dumps(report.to_json(floor), indent=2)


def test_findings_cost_bytes_per_frame_not_objects(tmp_path: Path) -> None:
    """tracemalloc counts what Python allocates (not time): eight times the broken frames may
    cost the two columns (12 bytes a finding, arrays grow by an eighth), not an object each."""

    def peak_bytes(records: int) -> int:
        path = empty_frames_pcap(tmp_path / f"{records}.pcap", records)

        def work() -> None:
            report = check_file(path)
            assert report.errors == records == len(report.findings)

        return traced_peak(work)

    peak_bytes(1_000)  # warm up: imports, caches
    small, large = 5_000, 40_000
    growth = peak_bytes(large) - peak_bytes(small)
    assert growth < 16 * (large - small), f"{growth / (large - small):.1f} bytes per finding"
