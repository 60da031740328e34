"""Peak memory of ``check``, ``decode`` and the Python iterator on a large generated capture.

issue 11, Build 3: readers stream, so peak RSS stays <= 256 MB however large the capture.
Writes a clean pcap of golden EPL and EtherCAT frames (1 ms apart) of about ``--bytes`` into a
temporary folder, runs each reader in a child process and reports its peak RSS (``wait4``) and
the seconds until its first line on stdout (``decode``). Run from the repository root::

    python benchmarks/bench_capture_memory.py                 # 300 MB
    python benchmarks/bench_capture_memory.py --bytes 2e9     # the issue's 2 GB case
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from skinframes import golden  # noqa: E402
from skinframes.pcap import PcapWriter  # noqa: E402

LIMIT_BYTES = 256 * 1024 * 1024
ITERATE = "import sys; from skinframes import read_capture\nprint(sum(1 for _ in read_capture(sys.argv[1])))"


def write_capture(path: Path, size_bytes: int) -> int:
    """About ``size_bytes`` of golden frames; returns the record count."""
    frames = [f for name in ("ecat_lrd_7x192", "epl_cycle_4cn") for _, f in golden.build(name)]
    count = written = 0
    with PcapWriter(path) as w:
        while written < size_bytes:
            f = frames[count % len(frames)]
            w.write(count * 1_000_000, f)
            count += 1
            written += 16 + len(f)
    return count


def measure(argv: list[str]) -> tuple[int, int, float, float]:
    """(exit status, peak RSS bytes, seconds to the first stdout line, seconds in all)."""
    start = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=ROOT)
    assert proc.stdout is not None
    proc.stdout.readline()
    first = time.perf_counter() - start
    for _ in iter(lambda: proc.stdout.read(1 << 16), b""):  # type: ignore[union-attr]
        pass
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, usage.ru_maxrss * 1024, first, time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bytes", type=float, default=300e6, help="capture size (default 300e6)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(dir=os.environ.get("TMPDIR")) as tmp:
        path = Path(tmp) / "big.pcap"
        count = write_capture(path, int(args.bytes))
        size = path.stat().st_size
        print(f"capture: {size / 1e6:.0f} MB, {count} records\n")
        print("| reader | exit | peak RSS [MB] | first line [s] | total [s] | <= 256 MB |")
        print("|---|---|---|---|---|---|")
        ok = True
        for name, argv in (
            ("check", [sys.executable, "-m", "skinframes", "check", str(path)]),
            ("decode", [sys.executable, "-m", "skinframes", "decode", str(path)]),
            ("read_capture iterator", [sys.executable, "-c", ITERATE, str(path)]),
        ):
            code, rss, first, total = measure(argv)
            fits = rss <= LIMIT_BYTES
            ok &= fits and code == 0
            print(
                f"| {name} | {code} | {rss / 1e6:.0f} | {first:.2f} | {total:.0f} | "
                f"{'yes' if fits else 'NO'} |"
            )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
