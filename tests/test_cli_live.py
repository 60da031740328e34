"""``decode``, ``check`` and ``analyze --iface``: live capture over a veth pair in a private
network namespace (issue 42, Build 1).

The expected frames are the ones the test sends itself through a raw socket on the other end of
the pair: built with the codecs, their bytes and counts known before anything is captured;
frames of other protocols (ARP, IPv6, DNS, a tagged ARP) are sent among them and must stay out.
Needs root (or CAP_NET_RAW + CAP_NET_ADMIN + CAP_SYS_ADMIN) and iproute2: skips loudly without,
fails under CI=true (the CI runs as root). The namespaces are named ``nd42-<pid>-<random>`` and
deleted on every way out (emulator.live.veth_netns).
"""

from __future__ import annotations

import json
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from pty_util import Terminal

from emulator.live import VethPair, _in_netns, netns_socket, veth_netns
from skinframes import ethercat, ethernet, powerlink
from skinframes.errors import InterfaceError
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.live_capture import LiveCapture, capture_filter

IN_CI = os.environ.get("CI", "").lower() == "true"
ROOT = Path(__file__).resolve().parent.parent
MASTER, SLAVE = "nd42m", "nd42s"
CAP_NET_RAW, CAP_NET_ADMIN, CAP_SYS_ADMIN = 13, 12, 21


def missing_requirement() -> str | None:
    if not sys.platform.startswith("linux"):
        return "live capture needs Linux (AF_PACKET, network namespaces)"
    with open("/proc/self/status", encoding="ascii") as f:
        cap_eff = next((int(x.split()[1], 16) for x in f if x.startswith("CapEff:")), 0)
    if os.geteuid() != 0 and not all(cap_eff >> c & 1 for c in (CAP_NET_RAW, CAP_NET_ADMIN,
                                                                 CAP_SYS_ADMIN)):  # fmt: skip
        return "needs root or CAP_NET_RAW + CAP_NET_ADMIN + CAP_SYS_ADMIN (raw sockets, netns)"
    if shutil.which("ip") is None:
        return "'ip' (iproute2) is not installed"
    return None


@pytest.fixture(scope="module")
def net() -> Iterator[VethPair]:
    reason = missing_requirement()
    if reason is not None:
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip("LIVE CAPTURE NOT TESTED: " + reason)
    with veth_netns(master=MASTER, slave=SLAVE, prefix="nd42") as pair:
        yield pair
    listed = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True, check=True)
    assert pair.netns not in listed.stdout


# --- the frames: built here, from the codecs --------------------------------------------------------
MASTER_MAC = bytes.fromhex("00005e005301")
RETURNED_MAC = bytes.fromhex("02005e005301")  # bit 0x02 of the first octet: passed an ESC


def _eth(dst: bytes, src: bytes, ethertype: int, payload: bytes) -> bytes:
    frame = dst + src + ethertype.to_bytes(2, "big") + payload
    return frame + bytes(max(0, ethernet.MIN_FRAME_BYTES - ethernet.FCS_BYTES - len(frame)))


def lrd(wkc: int, src: bytes) -> bytes:
    """An LRD of 8 bytes at logical 0 (the process data), as sent (wkc 0) or returned."""
    frame = ethercat.frame(EcatFrame((Datagram.logical(Command.LRD, 0, bytes(8), wkc=wkc),)))
    raw = frame.to_bytes()
    return raw[:6] + src + raw[12:]


def tagged(raw: bytes, vid: int) -> bytes:
    """``raw`` with an 802.1Q tag (TPID 0x8100, priority 0) of VLAN ``vid``."""
    return raw[:12] + b"\x81\x00" + vid.to_bytes(2, "big") + raw[12:]


def udp_ipv4(dport: int, payload: bytes) -> bytes:
    """IPv4/UDP from 192.168.100.240 to .1, checksums left 0 (RFC 768 allows none)."""
    udp = (0x4000).to_bytes(2, "big") + dport.to_bytes(2, "big")
    udp += (8 + len(payload)).to_bytes(2, "big") + b"\0\0" + payload
    ip = bytes([0x45, 0, *(20 + len(udp)).to_bytes(2, "big"), 0, 1, 0x40, 0, 64, 17, 0, 0])
    ip += bytes([192, 168, 100, 240, 192, 168, 100, 1])
    total = sum(int.from_bytes(ip[i : i + 2], "big") for i in range(0, 20, 2))
    while total >> 16:  # RFC 1071: the ones' complement sum of the header's 16-bit words
        total = (total & 0xFFFF) + (total >> 16)
    ip = ip[:10] + (~total & 0xFFFF).to_bytes(2, "big") + ip[12:]
    return _eth(b"\xff" * 6, MASTER_MAC, 0x0800, ip + udp)


def noise() -> list[bytes]:
    """Frames the capture filter keeps out: ARP, IPv6, DNS over UDP, a tagged ARP."""
    arp = _eth(b"\xff" * 6, MASTER_MAC, 0x0806, bytes(28))
    ipv6 = _eth(b"\x33\x33\0\0\0\1", MASTER_MAC, 0x86DD, bytes(40))
    dns = udp_ipv4(53, bytes(12))
    return [arp, ipv6, dns, tagged(arp, 7)]


def wanted() -> list[bytes]:
    """One of each kind the filter lets in (docs/interface.md)."""
    epl = powerlink.frame(powerlink.PRes(src=1, payload=bytes(8))).to_bytes()
    ecat_payload = lrd(0, MASTER_MAC)[14:]
    return [
        lrd(0, MASTER_MAC),
        lrd(1, RETURNED_MAC),
        epl,
        tagged(lrd(0, MASTER_MAC), 5),
        epl[:12] + b"\x88\xa8\x00\x03" + b"\x81\x00\x00\x09" + epl[12:],  # S-tag 3, C-tag 9
        udp_ipv4(3819, epl[14:]),  # EPL over UDP
        udp_ipv4(0x88A4, ecat_payload),  # EtherCAT over UDP
    ]


def send(pair: VethPair, frames: list[bytes], gap_s: float = 0.0) -> None:
    with netns_socket(SLAVE, pair.netns) as sock:
        for f in frames:
            sock.send(f)
            if gap_s:
                time.sleep(gap_s)


def live_capture(pair: VethPair, **kw: object) -> LiveCapture:
    with _in_netns(pair.netns):  # the socket stays in the namespace it was made in
        return LiveCapture(MASTER, **kw)  # type: ignore[arg-type]


# --- the capture itself: exact bytes, other traffic kept out --------------------------------------
def test_the_filter_lets_in_what_decode_reads_and_keeps_out_the_rest(net: VethPair) -> None:
    frames, other = wanted(), noise()
    mixed = [f for i, frame in enumerate(frames) for f in (other[i % len(other)], frame)]
    capture = live_capture(net, duration_s=5.0, count=len(frames))
    send(net, mixed)
    got = [r.data for r in capture]
    # byte for byte, in order; VLAN tags as sent (put back where the kernel took them off);
    # nothing of the noise
    assert got == frames
    assert list(capture) == []  # read once
    assert capture.total == len(frames) and capture.skipped == () and capture.findings == ()


def test_the_filter_is_small_and_jumps_only_forward() -> None:
    program = capture_filter()
    assert len(program) < 256
    assert program[-2:] == [(0x06, 0, 0, 65535), (0x06, 0, 0, 0)]  # accept, refuse


def test_no_interface_and_no_privilege_are_one_error_line(net: VethPair) -> None:
    with pytest.raises(InterfaceError, match="no such network interface"):
        live_capture(net, duration_s=1.0)._open("nd42none")
    run = [sys.executable, "-m", "skinframes", "check", "--iface", "nd42none"]
    done = subprocess.run(run, capture_output=True, text=True, timeout=60, cwd=ROOT, check=False)
    assert done.returncode == 2
    assert done.stderr == "skinframes: error: --iface nd42none: no such network interface\n"
    if shutil.which("setpriv") is None:
        return
    done = subprocess.run(
        ["setpriv", "--bounding-set", "-net_raw", *run[:-1], "lo", "--duration", "1"],
        capture_output=True, text=True, timeout=60, cwd=ROOT, check=False,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.startswith("skinframes: error: --iface lo: capturing needs root or CAP")
    assert done.stderr.count("\n") == 1


# --- the commands ----------------------------------------------------------------------------------
def in_netns(pair: VethPair, *argv: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        ["ip", "netns", "exec", pair.netns, sys.executable, "-m", "skinframes", *argv],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
    )  # fmt: skip


def wait_for_start(proc: subprocess.Popen[str]) -> str:
    """The 'Capturing on' line: the socket is open and filtered from then on."""
    assert proc.stderr is not None
    ready, _, _ = select.select([proc.stderr], [], [], 60)
    assert ready, "the capture did not start"
    line = proc.stderr.readline()
    assert line.startswith(f"Capturing on '{MASTER}'"), line
    return line


CYCLES = 600


def cycles() -> list[bytes]:
    """CYCLES process-data cycles as a master's port sees them: sent (wkc 0), returned (wkc 1)."""
    return [lrd(0, MASTER_MAC), lrd(1, RETURNED_MAC)] * CYCLES


def test_analyze_iface_reports_the_process_data_sent_and_returned(net: VethPair) -> None:
    # (analyze leaves VLAN-tagged frames aside, as it does in files: plain frames here)
    proc = in_netns(net, "analyze", "--iface", MASTER, "-c", str(2 * CYCLES + 1), "--duration",
                    "60", "--json")  # fmt: skip
    wait_for_start(proc)
    send(net, noise() + cycles() + wanted()[2:3], gap_s=0.0002)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    doc = json.loads(out)
    assert doc["path"] == f"{MASTER} (live)"
    assert doc["counts"] == {"epl": 1, "ecat": 2 * CYCLES, "other": 0}
    (pattern,) = doc["ecat"]["patterns"]
    assert pattern["datagrams"] == "LRD 0x00000000+8" and pattern["cyclic"]
    assert (pattern["frames"], pattern["returned"], pattern["unanswered"]) == (CYCLES, CYCLES, [])
    assert pattern["period"]["count"] == CYCLES - 1
    assert err.splitlines()[-1].startswith(f"{MASTER}: {2 * CYCLES + 1} frames in ")


def test_check_iface_counts_and_exit_status(net: VethPair) -> None:
    proc = in_netns(net, "check", "--iface", MASTER, "-c", "7", "--duration", "60")
    wait_for_start(proc)
    send(net, noise() + wanted())
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    lines = err.splitlines()
    assert (
        lines[-2].startswith(f"{MASTER}: 7 frames in ") and "0 dropped by the kernel" in lines[-2]
    )
    assert lines[-1].startswith(f"{MASTER} (live): 7 records (ecat 4, epl 3): 0 errors, 0 warnings")
    assert out == ""


def test_decode_iface_stops_on_ctrl_c_with_what_it_saw(net: VethPair) -> None:
    proc = in_netns(net, "decode", "--iface", MASTER, "--json")
    wait_for_start(proc)
    frames = wanted()
    send(net, noise() + frames)
    assert proc.stdout is not None
    seen = [json.loads(proc.stdout.readline()) for _ in frames]  # each line as it comes
    proc.send_signal(signal.SIGINT)
    rest, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert rest == ""
    assert [f["protocol"] for f in seen] == ["ecat", "ecat", "epl", "ecat", "epl", "epl", "ecat"]
    assert [f.get("vlan", [{}])[0].get("id") for f in seen] == [None, None, None, 5, 3, None, None]
    lines = err.splitlines()
    assert lines[-2] == f"{len(frames)} records: {len(frames)} decoded, 0 skipped"
    assert lines[-1].endswith("dropped by the kernel (stopped by Ctrl-C)")
    assert not any(line.startswith("skinframes") for line in lines)


def test_watch_iface_says_it_was_stopped_by_ctrl_c(net: VethPair) -> None:
    """watch's end line follows the live capture's rule, as check's and decode's (before, it
    left out ``(stopped by Ctrl-C)``: watch's own Ctrl-C handler stopped the capture)."""
    proc = in_netns(net, "watch", "--iface", MASTER, "--plain", "--interval", "0.001")
    wait_for_start(proc)
    send(net, wanted()[:2], gap_s=0.002)  # two frames 2 ms apart: a line, so watch is running
    assert proc.stdout is not None
    assert select.select([proc.stdout], [], [], 60)[0], "no line from watch"
    assert proc.stdout.readline().startswith("t ")
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert out.splitlines()[-1].endswith(" (end)")
    last = err.splitlines()[-1]
    assert re.fullmatch(rf"{MASTER}: \d+ frames in [\d.]+ s, 0 dropped by the kernel "
                        r"\(stopped by Ctrl-C\)", last), last  # fmt: skip


def test_a_second_ctrl_c_goes_to_the_handler_before(net: VethPair) -> None:
    """The first Ctrl-C ends the capture, and nothing is raised; a second goes to the handler
    before (the command's raises KeyboardInterrupt): a command still waiting to print, for a
    reader that does not read, ends at once (before, every Ctrl-C ended the capture again)."""
    capture = live_capture(net, duration_s=60.0)
    got: list[int] = []
    before = signal.signal(signal.SIGINT, lambda signum, frame: got.append(signum))
    try:
        with capture.sigint_stops():
            signal.raise_signal(signal.SIGINT)
            assert capture.interrupted and got == []
            signal.raise_signal(signal.SIGINT)
            assert got == [signal.SIGINT]
    finally:
        signal.signal(signal.SIGINT, before)
    assert list(capture) == []  # ended by the first
    assert signal.getsignal(signal.SIGINT) is before


def test_analyze_iface_ctrl_c_in_the_middle_reports_what_it_saw(net: VethPair) -> None:
    proc = in_netns(net, "analyze", "--iface", MASTER, "--json")
    wait_for_start(proc)
    send(net, cycles()[:200])
    # at once: what the kernel stamped before Ctrl-C is read, even if still in the socket
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    doc = json.loads(out)
    (pattern,) = doc["ecat"]["patterns"]
    assert (pattern["frames"], pattern["returned"]) == (100, 100)
    assert "(stopped by Ctrl-C)" in err


def test_usage_errors(net: VethPair) -> None:
    for argv, message in (
        (["decode", "--iface", MASTER, "--taxels", "t.npy"], "--taxels reads a capture file"),
        (["analyze", "x.pcap", "--iface", MASTER], "x.pcap and --iface nd42m: one input"),
        (["check"], "a capture file (PATH, - for standard input) or --iface IF"),
        (["check", "x.pcap", "-c", "0"], "-c/--count: 0: expected an integer in 1.."),
        (["decode", "--iface", MASTER, "--duration", "0"], "expected a number"),
    ):
        done = subprocess.run([sys.executable, "-m", "skinframes", *argv], capture_output=True,
                              text=True, timeout=60, cwd=ROOT, check=False)  # fmt: skip
        assert done.returncode == 2, argv
        (line,) = done.stderr.splitlines()
        assert line.startswith("skinframes: error: ") and message in line, (argv, line)


# --- acceptance: a real master (pysoem) against serve, captured on the master's end --------------
def test_analyze_iface_sees_a_real_masters_process_data(net: VethPair, tmp_path: Path) -> None:
    import importlib.util

    if importlib.util.find_spec("pysoem") is None:
        reason = "pysoem is not installed (pip install pysoem; it is in the test extra)"
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    serve = subprocess.Popen(
        ["ip", "netns", "exec", net.netns, sys.executable, "-m", "skinframes", "serve", "ecat",
         "--iface", SLAVE, "--nodes", "4", "--bytes", "192"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
    )  # fmt: skip
    try:
        assert serve.stderr is not None
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and "serving" not in serve.stderr.readline():
            pass
        capture = in_netns(net, "analyze", "--iface", MASTER, "--json")
        wait_for_start(capture)
        view = Terminal("watch", "--iface", MASTER, prefix=("ip", "netns", "exec", net.netns))
        view.read_until("[watching]")
        cycles = 1000
        master = subprocess.run(
            ["ip", "netns", "exec", net.netns, sys.executable, str(ROOT / "tests" / "soem_master.py"),
             MASTER, "--cycles", str(cycles), "--inputs-out", str(tmp_path / "in.bin")],
            capture_output=True, text=True, timeout=240, check=False, cwd=ROOT,
        )  # fmt: skip
        assert master.returncode == 0, master.stderr[-2000:]
        soem = json.loads(master.stdout.splitlines()[-1])
        capture.send_signal(signal.SIGINT)
        out, err = capture.communicate(timeout=120)
        assert capture.returncode == 0, err
        doc = json.loads(out)
        (pd,) = [p for p in doc["ecat"]["patterns"] if p["cyclic"]]  # SOEM: one LRW a cycle
        # the view, once its feed has read what analyze read (it may lag the wire: wait for
        # the count, not for a time; a view that never shows it fails here)
        screen = view.read_until(re.compile(rf"^ *{pd['frames']}\s+\d+\s+[\d.]+\s.*\sLRW ", re.M))
        view.press("q")
        assert view.wait() == 0
    finally:
        serve.send_signal(signal.SIGINT)
        serve.communicate(timeout=60)
    assert pd["datagrams"].startswith("LRW")
    assert pd["frames"] >= cycles >= 500 and pd["returned"] == pd["frames"]
    assert pd["unanswered"] == [] and set(soem["wkc"]) == {soem["expected_wkc"]}
    assert pd["steady_wkc"][0] == soem["expected_wkc"]
    # watch in a terminal shows the same period (its window: the last 2000 of 1000 cycles)
    row = re.search(r"^ *(\d+)\s+(\d+)\s+([\d.]+)\s.*\sLRW ", screen, re.M)
    assert row is not None, screen
    watched_us, measured_us = float(row[3]), pd["period"]["median_ns"] / 1000
    assert abs(watched_us - measured_us) <= 0.05 * measured_us, (watched_us, measured_us)
    assert int(row[1]) == pd["frames"] and int(row[2]) == 0
    print(
        f"watch: period median {watched_us} us; "
        f"process data: {pd['frames']} sent, {pd['returned']} returned, period median "
        f"{pd['period']['median_ns'] / 1000:.1f} us; SOEM's cycle median {soem['cycle_us']}"
    )
