"""WriteBehind: the writer does not wait for a slow sink until the thread is the bound behind,
nothing is dropped, and the sink's errors come back to the writer.

The slow sink is a stream whose ``write`` blocks until the test releases it, so nothing here
depends on how fast the machine is: a writer that waited for the sink would never return before
the release (the release also comes from a timer, 30 s on, so that such a failure ends).
"""

from __future__ import annotations

import errno
import io
import os
import threading
from pathlib import Path
from typing import BinaryIO, cast

import pytest

from skinframes import capture_writer, write_behind
from skinframes.pcap import CaptureWriter, read_capture
from skinframes.write_behind import CHUNK_BYTES, WriteBehind

RELEASE_S = 30.0  # the release a failing test gets from its timer


class HeldSink(io.BytesIO):
    """A stream whose writes wait until ``release`` is set; ``entered`` once one waits."""

    def __init__(self) -> None:
        super().__init__()
        self.release = threading.Event()
        self.entered = threading.Event()
        self.writes = 0

    def write(self, data: object) -> int:
        self.entered.set()
        self.release.wait()
        self.writes += 1
        return super().write(data)  # type: ignore[arg-type]


def released_later(sink: HeldSink) -> threading.Timer:
    timer = threading.Timer(RELEASE_S, sink.release.set)
    timer.daemon = True
    timer.start()
    return timer


def test_writes_return_while_the_sink_waits_and_nothing_is_dropped() -> None:
    sink = HeldSink()
    timer = released_later(sink)
    behind = WriteBehind(sink, close_sink=False)
    pieces = [os.urandom(1000 + k) for k in range(3000)]  # about 4.5 MB, many chunks
    for piece in pieces:
        behind.write(piece)
    assert sink.entered.wait(RELEASE_S)  # the thread took the first chunk and waits in write
    assert not sink.release.is_set(), "write() waited for the sink"
    sink.release.set()
    behind.close()
    timer.cancel()
    assert sink.getvalue() == b"".join(pieces)
    assert not sink.closed  # a stream is left open, flushed


def test_the_writer_waits_once_the_bound_is_held() -> None:
    # a bound of two chunks: with the sink held, the writer hands over two (the one being
    # written counts) and then waits for the third; an unbounded one would return all 8
    sink = HeldSink()
    timer = released_later(sink)
    behind = WriteBehind(sink, close_sink=False, held_bytes=2 * CHUNK_BYTES)
    chunk = bytes(CHUNK_BYTES)
    returned = []

    def writer() -> None:
        for k in range(8):
            behind.write(chunk)
            returned.append(k)

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    assert sink.entered.wait(RELEASE_S)
    thread.join(0.5)  # long enough for an unbounded writer to take all 8
    assert thread.is_alive() and len(returned) <= 2, returned
    sink.release.set()
    thread.join()
    behind.close()
    timer.cancel()
    assert len(returned) == 8
    assert sink.getvalue() == chunk * 8


class FullDisk(io.RawIOBase):
    def writable(self) -> bool:
        return True

    def write(self, data: object) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")


def test_an_error_of_the_sink_is_raised_by_the_next_call() -> None:
    behind = WriteBehind(cast(BinaryIO, FullDisk()), close_sink=True)
    behind.write(b"x" * 10)
    with pytest.raises(OSError, match="No space left") as raised:
        behind.flush()
    assert raised.value.errno == errno.ENOSPC
    with pytest.raises(OSError, match="No space left"):
        behind.write(b"more")
    behind.abort()  # as a capture writer leaving its with block does


def test_a_capture_that_meets_a_full_disk_leaves_the_previous_file(tmp_path: Path) -> None:
    path = tmp_path / "x.pcap"
    path.write_bytes(b"the previous capture")

    def full_disk_open(file: int, mode: str, buffering: int) -> FullDisk:
        os.close(file)  # the temporary file's descriptor: its writes fail from now on
        return FullDisk()

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(capture_writer, "open", full_disk_open, raising=False)
        writer = CaptureWriter(path, write_behind=True)
    with pytest.raises(OSError, match="No space left"), writer:
        for t in range(5):
            writer.write(t, bytes(60))
    assert path.read_bytes() == b"the previous capture"
    assert list(tmp_path.iterdir()) == [path]


def test_an_abort_drops_what_a_held_sink_has_not_taken(tmp_path: Path) -> None:
    sink = HeldSink()
    timer = released_later(sink)
    behind = WriteBehind(sink, close_sink=True)
    behind.write(bytes(3 * CHUNK_BYTES))
    assert sink.entered.wait(RELEASE_S)
    sink.release.set()  # the write under way ends; what is held is dropped
    behind.abort()
    timer.cancel()
    assert sink.closed and sink.writes <= 1


def test_an_abort_leaves_closing_to_a_thread_still_inside_its_write(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # closed under the thread, the sink's descriptor could be reused by a file opened meanwhile
    # and written to by the thread's next write
    monkeypatch.setattr(write_behind, "ABORT_WAIT_S", 0.01)
    sink = HeldSink()
    timer = released_later(sink)
    behind = WriteBehind(sink, close_sink=True)
    behind.write(bytes(3 * CHUNK_BYTES))
    assert sink.entered.wait(RELEASE_S)
    behind.abort()  # returns while the thread still waits inside write
    assert not sink.release.is_set() and not sink.closed
    sink.release.set()
    behind._thread.join(RELEASE_S)
    timer.cancel()
    assert sink.closed and sink.writes == 1  # the write under way, then nothing more


def test_a_capture_written_behind_reads_back_whole(tmp_path: Path) -> None:
    path = tmp_path / "x.pcapng"
    frames = [bytes([k % 256]) * (60 + k % 1400) for k in range(3000)]
    with CaptureWriter(path, write_behind=True) as writer:
        for t, frame in enumerate(frames):
            writer.write(t, frame, outbound=bool(t % 2))
    assert [(r.time_ns, r.data) for r in read_capture(path)] == list(enumerate(frames))


def test_a_pipe_gets_everything_and_stays_open() -> None:
    # a stream over a descriptor (as sys.stdout.buffer): what it had buffered comes first, the
    # thread writes the rest to the descriptor, and close leaves the stream open
    read_fd, write_fd = os.pipe()
    got = bytearray()
    reader = threading.Thread(target=lambda: got.extend(iter_pipe(read_fd)), daemon=True)
    reader.start()
    with open(write_fd, "wb") as stream:  # buffered, as sys.stdout.buffer is
        stream.write(b"before ")
        behind = WriteBehind(stream, close_sink=False)
        pieces = [os.urandom(700) for _ in range(500)]  # several chunks, more than a pipe holds
        for piece in pieces:
            behind.write(piece)
        behind.close()
        assert not stream.closed
    reader.join()
    assert bytes(got) == b"before " + b"".join(pieces)


def iter_pipe(fd: int) -> bytes:
    out = bytearray()
    while data := os.read(fd, 65536):
        out += data
    os.close(fd)
    return bytes(out)


def test_the_thread_leaves_sigint_and_sigterm_to_the_main_thread() -> None:
    """The writing thread blocks both: a Ctrl-C the kernel gave it while it waits for a
    reader would reach the main thread, waiting in close for it, only once that wait ended."""
    import signal

    masks: list[set[signal.Signals]] = []

    class Sink(io.BytesIO):
        def write(self, data: object) -> int:
            masks.append(signal.pthread_sigmask(signal.SIG_BLOCK, []))
            return super().write(data)  # type: ignore[arg-type]

    behind = WriteBehind(Sink(), close_sink=True)
    behind.write(b"x")
    behind.close()
    assert masks and {signal.SIGINT, signal.SIGTERM} <= masks[0]
    assert not {signal.SIGINT, signal.SIGTERM} & signal.pthread_sigmask(signal.SIG_BLOCK, [])
