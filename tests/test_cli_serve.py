"""``skinframes serve ecat``: argument checks and error lines (no root needed; the live runs are
in tests/emulator/test_live_soem.py)."""

from __future__ import annotations

import errno
import gc
import socket
import threading
import weakref
from pathlib import Path

import pytest
import tshark_util

from emulator.esc.chain import EcatChain
from emulator.live import FULL_EVERY, YOUNG_OBJECTS, BetweenFrames, ServeStats, serve
from skinframes import ethercat
from skinframes.capture_writer import CaptureWriter
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes_cli import main


class FakeSocket:
    """Stands in for AF_PACKET: ``bind`` fails like the kernel does for a missing interface."""

    def __init__(self, *args: object) -> None:
        pass

    def bind(self, addr: object) -> None:
        raise OSError(errno.ENODEV, "No such device")

    def close(self) -> None:
        pass


def denied(*args: object) -> None:
    raise PermissionError(errno.EPERM, "Operation not permitted")


@pytest.mark.parametrize(
    ("fake", "message"),
    [
        (FakeSocket, "no network interface 'ecs9'"),
        (denied, "opening a raw socket on 'ecs9' needs root or CAP_NET_RAW"),
    ],
)
def test_link_problems_are_one_error_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], fake: object, message: str
) -> None:
    monkeypatch.setattr(socket, "socket", fake)
    code = main(["serve", "ecat", "--iface", "ecs9", "--nodes", "3", "--bytes", "192"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(f"skinframes: error: {message}")
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--nodes", "0", "--bytes", "16"], "served EtherCAT chain: 0 slaves (1..1024)"),
        (["--nodes", "1025", "--bytes", "16"], "served EtherCAT chain: 1025 slaves (1..1024)"),
        # the count before the missing --bytes, which would not mend it
        (["--nodes", "70000"], "served EtherCAT chain: 70000 slaves (1..1024)"),
        (["--nodes", "2", "--bytes", "1487"], "EtherCAT: 1487 bytes per slave (1..1486)"),
        # the feed's and the clocks' limits, refused as the arguments are read (new: by name)
        (
            ["--nodes", "2", "--bytes", "16", "--samples", "0"],
            "argument --samples: 0: expected an integer in 1..1024",
        ),
        (
            ["--nodes", "2", "--bytes", "16", "--period-ms", "0"],
            "argument --period-ms: 0: expected a number above 0, up to 60000",
        ),
        (
            ["--nodes", "2", "--bytes", "16", "--period-ms", "-1"],
            "argument --period-ms: -1: expected a number above 0, up to 60000",
        ),
        (["--nodes", "2", "--bytes", "16", "--pcap", ""], "--pcap: an empty file name"),
        (
            ["--nodes", "2", "--bytes", "16", "--drift-ppm", "nan"],
            "argument --drift-ppm: 'nan': expected a finite number",
        ),
        (
            ["--nodes", "2", "--bytes", "16", "--drift-ppm", "1e400"],
            "argument --drift-ppm: '1e400': expected a finite number",
        ),
        (
            ["--nodes", "2", "--bytes", "16", "--drift-ppm", "-1"],
            "argument --drift-ppm: -1: expected a number in 0..200",
        ),
        (
            ["--nodes", "2", "--bytes", "16", "--drift-ppm", "201"],
            "argument --drift-ppm: 201: expected a number in 0..200",
        ),
    ],
)
def test_bad_arguments(capsys: pytest.CaptureFixture[str], args: list[str], message: str) -> None:
    """The limits are emulator.model.limits.check_served_ecat's (and the feed's and clocks',
    as the arguments are read); the check runs before any socket."""
    assert main(["serve", "ecat", "--iface", "lo", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"skinframes: error: {message}")
    assert err.count("\n") == 1


class PairSocket:
    """Stands in for :class:`emulator.live.RawSocket`: frames in from a list, answers kept; the
    stop event is set once every frame was read."""

    def __init__(self, frames: list[bytes], stop: threading.Event) -> None:
        self.inbox, self.outbox, self.stop = list(frames), [], stop
        self.r, self.w = socket.socketpair()
        self.w.send(b"x")  # select() sees something to read

    def fileno(self) -> int:
        return self.r.fileno()

    def receive(self) -> tuple[bytes, int] | None:
        if not self.inbox:
            self.stop.set()
            return None
        frame = self.inbox.pop(0)
        return frame, len(frame)

    def send(self, frame: bytes) -> None:
        self.outbox.append(frame)


def test_serve_counts_a_frame_it_cannot_process_records_all_and_goes_on(
    tmp_path: Path, tshark: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    chain = EcatChain.configured(2, 4)
    brd = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x0130, bytes(2)),))).to_bytes()
    boom = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x0EEE, bytes(2)),))).to_bytes()
    real = chain.answer

    def process(frame: bytes) -> bytes | None:  # an internal error on one frame
        if frame == boom:
            raise IndexError("simulated internal error")
        return real(frame)

    monkeypatch.setattr(chain, "answer", process)
    stop = threading.Event()
    sock = PairSocket([brd, boom, brd], stop)
    seen: list[bytes] = []
    path = tmp_path / "serve.pcapng"
    with CaptureWriter(path) as capture:
        stats = serve(
            chain, sock, stop, capture=capture, on_error=lambda exc, frame: seen.append(frame)
        )  # type: ignore[arg-type]
    assert (stats.frames_in, stats.frames_out, stats.errors) == (3, 2, 1)
    assert stats.error_messages == ["IndexError: simulated internal error"]
    assert seen == [boom]
    summary = stats.summary()
    assert summary["errors"] == 1 and summary["cpu_us_max"] >= 0
    # CPU times of every frame (the one not processed too), wall times of the answered ones
    assert (len(stats.cpu_us), len(stats.process_us)) == (3, 2)
    assert summary["cpu_us_median"] <= summary["cpu_us_p99"] <= summary["cpu_us_max"]
    # the answers: AL status OP (0x08) ORed over both slaves, working counter 2
    (d,) = ethercat.decode(sock.outbox[0][14:])[0].datagrams
    assert (d.data, d.wkc) == (b"\x08\x00", 2)
    # tshark reads every frame in and out, in order, with its direction (1 in, 0 out)
    rows = tshark_util.fields(tshark, path, ["frame.p2p_dir", "ecat.cnt"])
    assert [r["frame.p2p_dir"] for r in rows] == [["1"], ["0"], ["1"], ["1"], ["0"]]
    assert [r["ecat.cnt"] for r in rows] == [["0"], ["2"], ["0"], ["0"], ["2"]]
    assert tshark_util.problems(tshark, path) == []


class Cycle:
    """An object in a reference cycle: only the cyclic collector frees it."""

    def __init__(self) -> None:
        self.me = self


def test_serve_stats_percentiles_are_the_sorted_times_at_int_q_count() -> None:
    """serve's summary: the median and p99 of the kept CPU and wall times are the values at index
    int(q * count) of the sorted times (hand-computed here), rounded to 0.1 us; none kept: 0."""
    stats = ServeStats(cpu_us=[float(t) for t in range(200, 0, -1)], process_us=[7.26, 1.0, 3.0])
    summary = stats.summary()
    # 200 CPU times 1..200: index 100 -> 101, index 198 -> 199; wall 1, 3, 7.26: index 1 and 2
    assert (summary["cpu_us_median"], summary["cpu_us_p99"]) == (101.0, 199.0)
    assert (summary["process_us_median"], summary["process_us_p99"]) == (3.0, 7.3)
    empty = ServeStats().summary()
    assert (empty["cpu_us_median"], empty["cpu_us_p99"], empty["process_us_p99"]) == (0.0,) * 3


def test_serve_collects_garbage_between_frames_not_inside_them() -> None:
    """While serving, no collection starts inside a frame however many objects it makes; after
    the frame the young generations are collected, every FULL_EVERY-th time all of them, so
    cyclic garbage is still freed; what survives is frozen, so that no later collection walks
    it; the collector is as it was afterwards."""
    before = gc.isenabled()
    events: list[str] = []
    gc.callbacks.append(lambda phase, info: events.append(f"{phase} {info['generation']}"))
    try:
        with BetweenFrames() as collector:
            assert not gc.isenabled()
            events.clear()  # the full collection before freezing the chain's objects
            garbage = [Cycle() for _ in range(10 * YOUNG_OBJECTS)]  # a frame's worth, and more
            ref = weakref.ref(garbage[0])
            del garbage
            assert events == [] and ref() is not None  # nothing collected inside the frame
            collector.after_frame()
            assert events == ["start 1", "stop 1"] and ref() is None
            for _ in range(FULL_EVERY - 1):
                [Cycle() for _ in range(YOUNG_OBJECTS)]
                collector.after_frame()
            assert events[-2:] == ["start 2", "stop 2"]
            assert events.count("start 2") == 1
            # what survives is frozen: the next collection does not walk it again
            kept = [Cycle() for _ in range(3 * YOUNG_OBJECTS)]
            frozen = gc.get_freeze_count()
            collector.after_frame()
            assert gc.get_freeze_count() >= frozen + len(kept)
            assert gc.get_count() == (0, 0, 0)
        assert gc.get_freeze_count() == 0  # unfrozen afterwards
        with BetweenFrames(freeze=False) as collector:  # serve epl's: survivors not frozen
            frozen = gc.get_freeze_count()
            kept = [Cycle() for _ in range(3 * YOUNG_OBJECTS)]
            collector.after_frame()
            assert gc.get_freeze_count() <= frozen  # (refcounting may free a frozen one)
        assert gc.isenabled() == before
    finally:
        gc.callbacks.pop()


def test_serve_answers_before_the_firmware_reacts_and_goes_on_after_its_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """serve sends each answer before the slaves' firmware reacts to the frame: a BWR of AL
    control asking the OP slaves for PREOP is answered, then the ESM reacts (each such write is
    a reaction, datasheet II 0x0120). An internal error in the firmware's reaction is counted
    (the frame was answered) and serving goes on; a frame that leaves the firmware nothing to
    react to (a BRD of AL status) does not run it."""
    chain = EcatChain.configured(2, 4)
    to_preop = ethercat.frame(EcatFrame((Datagram(Command.BWR, 0, 0x0120, b"\x02\x00"),)))
    status = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x0130, bytes(2)),))).to_bytes()
    order: list[str] = []
    answer, firmware = chain.answer, chain.run_firmware

    def answered(frame: bytes) -> bytes | None:
        order.append("answer")
        return answer(frame)

    def reacted() -> None:
        order.append("firmware")
        if len(order) == 9:  # after the third frame
            raise KeyError("simulated firmware error")
        firmware()

    monkeypatch.setattr(chain, "answer", answered)
    monkeypatch.setattr(chain, "run_firmware", reacted)
    stop = threading.Event()
    sock = PairSocket([to_preop.to_bytes()] * 3 + [status], stop)
    send = sock.send

    def sent(frame: bytes) -> None:
        order.append("send")
        send(frame)

    monkeypatch.setattr(sock, "send", sent)
    stats = serve(chain, sock, stop)  # type: ignore[arg-type]
    assert order == ["answer", "send", "firmware"] * 3 + ["answer", "send"]
    assert (stats.frames_in, stats.frames_out, stats.errors) == (4, 4, 1)
    assert stats.error_messages == ["KeyError: 'simulated firmware error'"]
    assert stats.summary()["firmware_us_max"] >= 0
    for back in sock.outbox[1:]:  # AL status PREOP (0x02) ORed over both slaves, wkc 2
        (d,) = ethercat.decode(back[14:])[0].datagrams
        assert (d.data, d.wkc) == (b"\x02\x00", 2)
