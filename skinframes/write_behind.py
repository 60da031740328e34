"""Writing behind: a file's bytes written by a thread of their own.

A program that answers frames as they come (``skinframes serve``) must not wait for its capture
file: a pipe holds 64 KiB, so a writer waits as long as the reader (Wireshark, tshark) pauses, and
a file's flushed buffer is copied into the kernel's page cache, which takes milliseconds a MiB on
a VM and longer while the kernel throttles writers of dirty pages.
:class:`WriteBehind` takes the bytes at once and a daemon thread writes them.

Nothing is dropped: when the thread is :data:`HELD_BYTES` behind, ``write`` waits for it, so the
memory held stays bounded. An exception of the thread (``OSError``: a full disk, a pipe whose
reader went) is raised by the next ``write``, ``flush`` or ``close``.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections import deque
from typing import BinaryIO, Final

from skinframes.helper_threads import MAIN_WAIT_S, leave_signals_to_main

# gathered before the thread gets them; under glibc's mmap threshold (128 KiB), so that a chunk
# comes from the heap: chunks of 1 MiB, each a fresh mapping whose pages fault in, held the
# writer up 1-9 ms each (benchmarks/bench_capture_stall.py; 64 KiB: at most 0.7 ms)
CHUNK_BYTES: Final = 1 << 16
HELD_BYTES: Final = 64 << 20  # at most this much (and one write more) waits for the thread
ABORT_WAIT_S: Final = 1.0  # how long abort() waits for a thread inside a write (a stuck pipe)


class WriteBehind:
    """The ``write``/``flush``/``close`` of a binary file, the writing done by a daemon thread.

    Args:
        sink: where the bytes go (an unbuffered file, a stream such as ``sys.stdout.buffer``);
            only the thread writes to it while this object is open.
        close_sink: whether :meth:`close` and :meth:`abort` close ``sink`` (a file this program
            opened) or leave it open, flushed (a stream its owner closes).
        held_bytes: how far the thread may fall behind before ``write`` waits.
    """

    def __init__(self, sink: BinaryIO, *, close_sink: bool, held_bytes: int = HELD_BYTES) -> None:
        self._sink = sink
        self._fd = _descriptor(sink)  # the thread writes to it, not through the stream's lock
        self._close_sink = close_sink
        self._held_limit = held_bytes
        self._gathered = bytearray()
        self._chunks: deque[bytearray] = deque()
        self._held = 0  # bytes handed to the thread and not yet written
        self._error: Exception | None = None
        self._ending = False  # no more chunks come: the thread ends once it has written the held
        self._dropping = False  # abort(): the held chunks are dropped
        self._closes_sink = False  # abort() left closing the sink to the thread, still writing
        self._finished = False  # the thread writes no more (set as it ends, under the lock)
        self._cond = threading.Condition()
        self._thread = threading.Thread(target=self._run, name="write-behind", daemon=True)
        self._thread.start()

    def write(self, data: bytes | bytearray | memoryview) -> int:
        """Take ``data`` (copied: the caller may reuse its buffer); returns its length."""
        self._raise()
        self._gathered += data
        if len(self._gathered) >= CHUNK_BYTES:
            self._hand_over()
        return len(data)

    def flush(self) -> None:
        """Wait until the thread has written everything taken so far, then flush ``sink``."""
        if self._gathered:
            self._hand_over()
        with self._cond:
            while self._held and self._error is None:
                self._cond.wait(MAIN_WAIT_S)  # (a Ctrl-C meanwhile is handled)
        self._raise()
        self._sink.flush()

    def close(self) -> None:
        """Write everything, end the thread, and close ``sink`` (``close_sink``) or leave it
        flushed."""
        try:
            self.flush()
        except BaseException:  # what is left cannot be written, or must not be waited for
            self.abort()
            raise
        self._end(drop=False)  # the thread has nothing left: it ends at once
        if self._close_sink:
            self._sink.close()

    def abort(self) -> None:
        """Drop what the thread has not written, end it, and close ``sink`` (``close_sink``);
        waits at most :data:`ABORT_WAIT_S` for a write under way (a pipe nobody reads). A thread
        still inside its write then closes ``sink`` itself when the write returns: closed here,
        its descriptor could be reused by a file opened meanwhile and written to by the thread."""
        self._gathered.clear()
        self._end(drop=True)
        if self._close_sink:
            with self._cond:
                if not self._finished:
                    self._closes_sink = True
                    return
            self._close_quietly()

    # --- internals ---
    def _raise(self) -> None:
        if self._error is not None:
            raise self._error

    def _hand_over(self) -> None:
        chunk, self._gathered = self._gathered, bytearray()
        with self._cond:
            while self._held and self._held + len(chunk) > self._held_limit:
                if self._error is not None:
                    break
                self._cond.wait(MAIN_WAIT_S)
            self._raise()
            self._chunks.append(chunk)
            self._held += len(chunk)
            self._cond.notify_all()

    def _end(self, *, drop: bool) -> None:
        with self._cond:
            self._ending = True
            if drop:
                self._dropping = True
                self._chunks.clear()
                self._held = 0
            self._cond.notify_all()
        self._thread.join(ABORT_WAIT_S if drop else None)

    def _close_quietly(self) -> None:
        with contextlib.suppress(OSError):
            self._sink.close()

    def _run(self) -> None:
        leave_signals_to_main()  # (a Ctrl-C taken here would not reach a waiting close)
        try:
            self._write_chunks()
        finally:
            with self._cond:
                self._finished = True
                closes = self._closes_sink
            if closes:
                self._close_quietly()

    def _write_chunks(self) -> None:
        while True:
            with self._cond:
                while not self._chunks and not self._ending:
                    self._cond.wait()
                if not self._chunks or self._dropping:
                    return
                chunk = self._chunks[0]
            try:
                view = memoryview(chunk)
                while view and not self._dropping:  # a write may take part of it
                    done = self._sink.write(view) if self._fd is None else os.write(self._fd, view)
                    view = view[done or 0 :]
            except Exception as exc:  # raised by the writer's next call instead
                with self._cond:
                    self._error = exc
                    self._chunks.clear()
                    self._held = 0
                    self._cond.notify_all()
                return
            with self._cond:
                if self._chunks and self._chunks[0] is chunk:
                    self._chunks.popleft()
                    self._held -= len(chunk)
                self._cond.notify_all()


def _descriptor(sink: BinaryIO) -> int | None:
    """The file descriptor under ``sink``, its buffer flushed, or None (an in-memory stream).
    The thread writes to the descriptor: a thread stuck in a write to a pipe would otherwise
    hold the stream's lock, which Python takes again at exit (``sys.stdout``)."""
    try:
        fd = sink.fileno()
    except (OSError, ValueError):  # io.UnsupportedOperation is both
        return None
    sink.flush()
    return fd
