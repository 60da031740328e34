"""Peak memory of ``check``, ``decode``, ``decode --taxels`` and the Python iterator on a large
generated capture.

issue 11, Build 3: readers stream, so peak RSS stays <= 256 MB however large the capture.
Writes a clean pcap of golden EPL and EtherCAT frames (1 ms apart) of about ``--bytes`` into a
temporary folder, runs each reader in a child process and reports its peak RSS (``wait4``) and
the seconds until its first line on stdout (``decode``). Peak RSS is the child's own ``VmHWM``
(``/proc/self/status``, reset by exec): ``wait4``'s ``ru_maxrss`` would also count the parent's
pages from before the exec. Run from the repository root::

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
# run one reader, then report the process's peak RSS on stderr's last line
CHILD = """
import sys
from skinframes import read_capture
from skinframes_cli import main
kind, path = sys.argv[1], sys.argv[2]
if kind == "iterate":
    print(sum(1 for _ in read_capture(path)))
    code = 0
elif kind == "decode --taxels":
    code = main(["decode", "--taxels", path + ".npy", path])
    print("written")
else:
    code = main([kind, path])
    sys.stdout.flush()
with open("/proc/self/status") as f:
    hwm_kib = next(line.split()[1] for line in f if line.startswith("VmHWM"))
sys.stderr.write(f"\\nVmHWM {hwm_kib}\\n")
raise SystemExit(code)
"""
READERS = ("check", "decode", "decode --taxels", "iterate")


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


def measure(
    kind: str, path: Path | str, stdin: Path | None = None
) -> tuple[int, int, float, float]:
    """(exit status, peak RSS bytes, seconds to the first stdout line, seconds in all) of one
    reader (``check``, ``decode`` or ``iterate``) on ``path`` (``-``: ``stdin``)."""
    start = time.perf_counter()
    with open(stdin or os.devnull, "rb") as inp:
        proc = subprocess.Popen(
            [sys.executable, "-c", CHILD, kind, str(path)],
            stdin=inp,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            cwd=ROOT,
        )
        assert proc.stdout is not None and proc.stderr is not None
        proc.stdout.readline()
        first = time.perf_counter() - start
        for _ in iter(lambda: proc.stdout.read(1 << 16), b""):  # type: ignore[union-attr]
            pass
        err = proc.stderr.read().decode()
        code = proc.wait()
    hwm_kib = int(err.rsplit("VmHWM", 1)[1].split()[0])
    return code, hwm_kib * 1024, first, time.perf_counter() - start


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
        for kind in READERS:
            code, rss, first, total = measure(kind, path)
            fits = rss <= LIMIT_BYTES
            ok &= fits and code == 0
            print(
                f"| {kind} | {code} | {rss / 1e6:.0f} | {first:.2f} | {total:.0f} | "
                f"{'yes' if fits else 'NO'} |"
            )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
