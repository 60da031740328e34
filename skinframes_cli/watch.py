"""``skinframes watch PATH|--iface IF``: a live view of an EPL or EtherCAT network, in the
spirit of python-can's ``can.viewer``.

A reader thread feeds the frames (a live capture, or a file replayed at its own pace, ``--speed``)
into a :class:`skinframes.monitor.Monitor`; the main thread shows its figures. On a terminal:
a view drawn with rich, redrawn four times a second, keys ``q`` (quit) and ``p`` or space
(pause the view; the reading goes on); at the end of a file the view stays until ``q``. Not on
a terminal (or ``--plain``): one line of figures every ``--interval`` seconds of capture time and
a last one at the end. Ctrl-C ends the view, exit 0.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import select
import signal
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterator
from typing import Any, Final

from skinframes.helper_threads import MAIN_WAIT_S, leave_signals_to_main
from skinframes.monitor import Monitor
from skinframes.text import escape
from skinframes_cli.live import add_live, capture_input, first_frames, is_live, report_records
from skinframes_cli.options import bounded_float, in_path
from skinframes_cli.signals import first_stops

REFRESH_S: Final = 0.25  # the terminal view is redrawn this often
ROWS_MAX: Final = 16  # nodes or patterns listed one a row; beyond, summarised
PATCHES_PER_ROW: Final = 40
CONTACT_SHADES: Final = ((0, "·"), (1, "░"), (4, "▒"), (8, "▓"), (12, "█"))  # triangles -> glyph


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "watch",
        help="a live view of a network: cycle, nodes, states, taxels (like can.viewer)",
        description="Watch an EPL or EtherCAT network as its frames come, from a live interface "
        "(--iface) or a capture file replayed at its own pace: per protocol the cycle period "
        "and jitter, per EPL CN the response time, missing answers and NMT state, per "
        "EtherCAT cyclic pattern the round trip, lost frames and working-counter deviations, "
        "AL states, and per patch the triangles in contact. Keys: q quits, p pauses. Not on "
        "a terminal: one line every --interval seconds.",
    )
    p.add_argument(
        "path",
        nargs="?",
        type=in_path,
        metavar="PATH",
        help="capture file (pcap, pcapng, gzip); - for stdin (or --iface)",
    )
    add_live(p)
    p.add_argument(
        "--speed",
        type=bounded_float(0, 1e6),
        default=1.0,
        metavar="X",
        help="a file replayed X times its own pace (default 1; 0: as fast as it reads)",
    )
    p.add_argument(
        "--interval",
        type=bounded_float(0.001, 3600),
        default=1.0,
        metavar="S",
        help="plain output: one line every S seconds of capture time (default 1)",
    )
    p.add_argument(
        "--plain", action="store_true", help="lines of text even on a terminal (no view)"
    )
    p.set_defaults(run=run)


# --- reading (a thread) ---------------------------------------------------------------------------
class Feed:
    """The reader thread: frames into the monitor, under a lock; a file at its pace. With
    ``every_s`` (plain output) it also prints a line each time the capture's time passes another
    ``every_s`` seconds: lines by capture time, however fast the frames are read."""

    def __init__(self, records: Any, speed: float, live: Any, every_s: float | None = None) -> None:
        self.monitor = Monitor()
        self.every_s = every_s
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.done = threading.Event()
        self.error: BaseException | None = None
        self._records, self._speed, self._live = records, speed, live
        self.thread = threading.Thread(target=self._run, name="watch-feed", daemon=True)

    def start(self) -> None:
        """Start reading."""
        self.thread.start()

    def halt(self) -> None:
        """Stop reading (a live capture ends at its next look)."""
        self.stop.set()
        if self._live is not None:
            self._live.stop()

    def interrupt(self) -> None:
        """Stop reading as Ctrl-C does (a live capture says it was interrupted)."""
        if self._live is not None:
            self._live.interrupt()
        self.halt()

    def _run(self) -> None:
        leave_signals_to_main()  # (a Ctrl-C taken here would not reach the waiting main thread)
        records: Any = ()
        try:
            records = iter(self._records)
            start_wall: float | None = None
            first_ns = 0
            every = self.every_s
            next_s = every or 0.0
            for rec in records:
                if self.stop.is_set():
                    break
                if self._live is None and self._speed > 0:
                    if start_wall is None:
                        start_wall, first_ns = time.monotonic(), rec.time_ns
                    due = start_wall + (rec.time_ns - first_ns) / 1e9 / self._speed
                    while not self.stop.is_set() and (wait := due - time.monotonic()) > 0:
                        time.sleep(min(wait, 0.05))
                line = None
                with self.lock:
                    self.monitor.feed(rec)
                    if every is not None and (span := self.monitor.span_s) >= next_s:
                        # one line, however many intervals the capture skipped
                        line = plain_line(self.monitor.snapshot())
                        next_s = (span // every + 1) * every
                if line is not None:  # (the lock free while a reader of stdout waits)
                    _emit(line)
        except BaseException as exc:  # handed to the main thread, which reports it
            self.error = exc
        finally:
            close = getattr(records, "close", None)
            if close is not None:  # a stop before the end: the records skipped of those read
                close()
            if self.error is None:
                with self.lock:
                    self.monitor.skipped = tuple(getattr(self._records, "skipped", ()))
            self.done.set()

    def snapshot(self) -> dict[str, Any]:
        """The monitor's figures now."""
        with self.lock:
            return self.monitor.snapshot()


# --- the command ------------------------------------------------------------------------------------
def run(args: argparse.Namespace) -> int:
    """Watch until the end of the file, q, Ctrl-C or the capture's limits."""
    terminal = sys.stdout.isatty() and not args.plain
    every = None if terminal else args.interval
    with contextlib.ExitStack() as stack:
        if is_live(args):
            live = stack.enter_context(capture_input(args, args.count))
            feed = Feed(live, 0, live, every)
            source = f"{args.iface} (live)"
        else:
            feed = Feed(first_frames(args), args.speed, None, every)
            source = args.path
        stop = stack.enter_context(_sigint_event(feed))
        feed.start()
        if terminal:
            _view(feed, source, stop)
        else:
            _lines(feed, stop)
        feed.halt()
        while feed.thread.is_alive():  # (MAIN_WAIT_S at a time: a Ctrl-C is handled meanwhile)
            feed.thread.join(MAIN_WAIT_S)
    if feed.error is not None:
        raise feed.error
    skipped, n = feed.monitor.skipped, feed.monitor.analyzer.records
    if skipped:  # as decode reports them
        report_records(n + len(skipped), n, skipped)
    return 0


@contextlib.contextmanager
def _sigint_event(feed: Feed) -> Iterator[threading.Event]:
    """Ctrl-C (main thread) ends the watch: the reading stops and the command ends with 0; a
    second Ctrl-C ends it at once, 130, while it still waits (a reader of stdout that does not
    read; :func:`first_stops`)."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def interrupted() -> None:
        stop.set()
        feed.interrupt()

    with first_stops(interrupted, (signal.SIGINT,)):
        yield stop


def _emit(line: str) -> None:
    """Print ``line`` on stdout: written to its descriptor when it has one, so that a thread
    waiting for a reader of stdout holds no lock of Python's (whose stdout, flushed at exit,
    would wait for that lock: a second Ctrl-C could not end the command)."""
    try:
        fd = sys.stdout.fileno()
    except (OSError, ValueError):  # io.UnsupportedOperation is both: no descriptor
        print(line, flush=True)
        return
    sys.stdout.flush()
    encoding = getattr(sys.stdout, "encoding", None) or "utf-8"
    data = memoryview((line + "\n").encode(encoding, "replace"))
    while data:
        # no write before stdout takes one, waited for MAIN_WAIT_S at a time: a Ctrl-C that
        # came as a blocking write began would be handled only once the reader read
        if select.select([], [fd], [], MAIN_WAIT_S)[1]:
            data = data[os.write(fd, data) :]


# --- plain: lines --------------------------------------------------------------------------------
def _lines(feed: Feed, stop: threading.Event) -> None:
    """The reader prints the lines as the capture's time passes; here the last one."""
    while not stop.is_set() and not feed.done.wait(0.05):
        pass
    _emit(plain_line(feed.snapshot()) + " (end)")


def _us(s: dict[str, float] | None, key: str = "median_us") -> str:
    return "-" if s is None else f"{s[key]:.1f}"


def plain_line(doc: dict[str, Any]) -> str:
    """One line of the figures (the plain output)."""
    parts = [f"t {doc['span_s']:.3f} s", f"frames {doc['frames']}"]
    if "epl" in doc:
        e = doc["epl"]
        cns = e["cns"]
        states = Counter(c["state"] for c in cns if c["state"])
        parts.append(
            f"epl: period {_us(e['soc_period'])} us jitter {_us(e['soc_period'], 'jitter_us')}"
            f" us, {len(cns)} CNs, missing {sum(c['missing'] for c in cns)}"
            + (", " + " ".join(f"{k} {v}" for k, v in states.most_common()) if states else "")
        )
    if "ecat" in doc:
        e = doc["ecat"]
        for p in e["patterns"][:1]:  # the busiest cyclic pattern
            parts.append(
                f"ecat: {p['datagrams'].split(',')[0]}...: period {_us(p['period'])} us jitter "
                f"{_us(p['period'], 'jitter_us')} us, round trip {_us(p['round_trip'])} us, "
                f"sent {p['sent']} lost {p['lost']}, wkc {p['wkc'][0]} deviations "
                f"{sum(q['wkc_deviations'] for q in e['patterns'])}"
            )
        states = Counter(e["al_states"].values())
        if states:
            parts.append("AL " + " ".join(f"{k} {v}" for k, v in states.most_common()))
    contact = doc["contact"]
    if contact:
        parts.append(f"contact: {sum(1 for v in contact.values() if v)} of {len(contact)} patches")
    return "  ".join(parts)


# --- terminal: a view ------------------------------------------------------------------------------
@contextlib.contextmanager
def _keys() -> Iterator[Any]:
    """Single key presses from stdin while it is a terminal (cbreak, no echo); else none."""
    if not sys.stdin.isatty():
        yield lambda: ""
        return
    import termios
    import tty

    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    tty.setcbreak(fd)

    def read() -> str:
        if select.select([fd], [], [], 0)[0]:
            return os.read(fd, 16).decode(errors="replace")
        return ""

    try:
        yield read
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def _view(feed: Feed, source: str, stop: threading.Event) -> None:
    from rich.console import Console
    from rich.live import Live

    console = Console()
    paused = False
    doc = feed.snapshot()
    with _keys() as key, Live(console=console, auto_refresh=False, screen=False) as live:
        while not stop.is_set():
            pressed = key()
            if "q" in pressed or "Q" in pressed:
                break
            if "p" in pressed or " " in pressed:
                paused = not paused
            ended = feed.done.is_set()
            if not paused:
                doc = feed.snapshot()
            live.update(render(doc, source, paused=paused, ended=ended), refresh=True)
            stop.wait(REFRESH_S if not ended else 0.1)


def _shade(triangles: int) -> str:
    glyph = CONTACT_SHADES[0][1]
    for at_least, g in CONTACT_SHADES:
        if triangles >= at_least:
            glyph = g
    return glyph


def render(doc: dict[str, Any], source: str, *, paused: bool, ended: bool) -> Any:
    """The view of a snapshot (a rich renderable)."""
    from rich.console import Group
    from rich.table import Table
    from rich.text import Text

    state = "paused" if paused else ("end of capture" if ended else "watching")
    head = Text.assemble(
        ("skinframes watch ", "bold"),
        escape(source),
        f"  {doc['frames']} frames in {doc['span_s']:.3f} s  [{state}]  q quits, p pauses",
    )
    parts: list[Any] = [head]
    if doc.get("skipped"):
        parts.append(
            Text(
                f"skipped: {doc['skipped']} records could not be read (listed on stderr at the end)"
            )
        )
    if "epl" in doc:
        e = doc["epl"]
        s = e["soc_period"]
        parts.append(
            Text(
                f"EPL: {e['frames']} frames, {e['cycles']} cycles; SoC period median "
                f"{_us(s)} us, jitter {_us(s, 'jitter_us')} us (min {_us(s, 'min_us')}, max "
                f"{_us(s, 'max_us')})"
            )
        )
        t = Table("CN", "state", "polled", "missing", "response us", "jitter us", box=None)
        cns = e["cns"]
        shown = sorted(cns, key=lambda c: (-c["missing"], c["node"]))[:ROWS_MAX]
        for c in sorted(shown, key=lambda c: c["node"]):
            t.add_row(str(c["node"]), c["state"] or "-", str(c["polled"]), str(c["missing"]),
                      _us(c["response"]), _us(c["response"], "jitter_us"))  # fmt: skip
        parts.append(t)
        if len(cns) > ROWS_MAX:
            states = Counter(c["state"] for c in cns if c["state"])
            medians = [c["response"]["median_us"] for c in cns if c["response"]]
            parts.append(
                Text(
                    f"  ... {len(cns) - ROWS_MAX} more CNs (those missing most are listed); "
                    f"all {len(cns)}: missing {sum(c['missing'] for c in cns)}, response "
                    f"{min(medians, default=0):.1f}..{max(medians, default=0):.1f} us, "
                    + " ".join(f"{k} {v}" for k, v in states.most_common())
                )
            )
    if "ecat" in doc:
        e = doc["ecat"]
        parts.append(Text(f"EtherCAT: {e['frames']} frames, {len(e['patterns'])} cyclic patterns"))
        t = Table("sent", "lost", "period us", "jitter us", "round trip us", "wkc",
                  "deviations", "pattern", box=None)  # fmt: skip
        for p in e["patterns"][:ROWS_MAX]:
            name = p["datagrams"] if len(p["datagrams"]) <= 40 else p["datagrams"][:37] + "..."
            t.add_row(str(p["sent"]), str(p["lost"]), _us(p["period"]),
                      _us(p["period"], "jitter_us"), _us(p["round_trip"]),
                      ",".join(map(str, p["wkc"][:4])) + ("..." if len(p["wkc"]) > 4 else ""),
                      str(p["wkc_deviations"]), name)  # fmt: skip
        parts.append(t)
        states = e["al_states"]
        if states:
            if len(states) <= ROWS_MAX:
                line = ", ".join(f"{k} {v}" for k, v in states.items())
            else:
                line = " ".join(f"{k} {v}" for k, v in Counter(states.values()).most_common())
            parts.append(Text(f"AL states: {line}"))
    contact = doc["contact"]
    if contact:
        last = max(contact)
        rows = []
        for start in range(0, last + 1, PATCHES_PER_ROW):
            glyphs = "".join(
                _shade(contact[i]) if i in contact else " "
                for i in range(start, min(start + PATCHES_PER_ROW, last + 1))
            )
            rows.append(f"  {start:>4} {glyphs}")
        legend = " ".join(f"{g} {n}+" for n, g in CONTACT_SHADES)
        touched = sum(1 for v in contact.values() if v)
        parts.append(
            Text(
                f"Taxels: triangles in contact per patch ({touched} of {len(contact)} patches "
                f"touched; {legend})\n" + "\n".join(rows)
            )
        )
    return Group(*parts)
