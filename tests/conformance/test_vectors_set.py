"""The conformance vector set: tshark decodes each frame with the fields its JSON line states,
and the malformed ones carry the finding the JSON names."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import tshark_util

from skinframes import decode_frame, read_capture
from skinframes_cli import main

pytestmark = pytest.mark.tshark


def test_vector_set_agrees_with_tshark(
    tshark: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["vectors", "--out", str(tmp_path)]) == 0
    pcap, jsonl = tmp_path / "vectors.pcap", tmp_path / "vectors.jsonl"
    assert capsys.readouterr().out.split() == [str(pcap), str(jsonl)]
    lines = [json.loads(line) for line in jsonl.read_text().splitlines()]
    records = list(read_capture(pcap))
    assert [o["frame"] for o in lines] == list(range(1, len(records) + 1))
    names = sorted({name for o in lines for name in o["fields"]})
    rows = tshark_util.fields(tshark, pcap, names)
    malformed = {
        int(line.split("\t")[0])
        for line in tshark_util.run(
            tshark, pcap, "-Y", "_ws.malformed", "-T", "fields", "-e", "frame.number"
        ).split()
    }
    for o, row, rec in zip(lines, rows, records, strict=True):
        assert decode_frame(rec.data).to_bytes() == rec.data
        assert o["length"] == len(rec.data)
        bad = o["name"].startswith("bad.")
        if bad:
            assert o["name"][4:] in [f["code"] for f in o["findings"]], o
        else:
            assert [f for f in o["findings"] if f["severity"] != "info"] == [], o
            assert o["frame"] not in malformed, o
        if o["frame"] in malformed:
            continue
        for name, values in o["fields"].items():
            assert [int(v, 0) for v in row[name]] == values, (o["name"], name, row[name])
    kinds = {o["name"].split(".")[1] for o in lines if o["name"].startswith("ecat.")}
    assert {"NOP", "APRD", "FRMW", "LRW", "type4_nv", "type5_mailbox"} <= kinds
    assert len(lines) >= 80


@pytest.mark.parametrize("refused", ["vectors.pcap", "vectors.jsonl"])
def test_the_set_is_written_whole_or_not_at_all(
    refused: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A symbolic link in place of either file is refused (never written through), and the
    other file is not written either: once vectors.pcap was, beside a refused vectors.jsonl."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.write_text("keep")
    out = tmp_path / "out"
    out.mkdir()
    (out / refused).symlink_to(elsewhere)
    assert main(["vectors", "--out", str(out)]) == 2
    assert "symbolic link" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [refused]
    assert elsewhere.read_text() == "keep"
