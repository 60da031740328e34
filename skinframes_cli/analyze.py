"""``skinframes analyze CAPTURE``: cycle statistics of an EPL or EtherCAT capture.

What is measured lives in :mod:`skinframes.analysis`; this module reads the capture with a
progress bar, puts the emulator's cycle time for the inferred network (``wire`` preset) beside
the measured period, and prints text, JSON, CSV tables or a picture.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path
from typing import Any, Final

from emulator import WIRE, EmulatorError, simulate_ecat, simulate_epl
from skinframes.analysis import Analysis, InferredConfig, Summary, analyze_capture, analyze_file
from skinframes.analysis.ecat import EcatAnalysis
from skinframes.analysis.epl import EplAnalysis
from skinframes.atomic_file import atomic_output, output_folder
from skinframes.errors import SkinframesError
from skinframes.powerlink import NmtState
from skinframes_cli.decode import open_capture
from skinframes_cli.figure import save_figure
from skinframes_cli.progress import progress_bar

MODEL_PRESET: Final = "wire"
TEXT_LIST_LIMIT: Final = 20  # lines per event list in the text report; JSON and CSV list all
_NS_PER_US: Final = 1000


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "analyze",
        help="cycle statistics of an EPL or EtherCAT capture",
        description="EPL: SoC period, PReq->PRes response times, missing and late responses, "
        "NMT states, ASnd services, NMT commands and error entries. EtherCAT: cyclic frames by "
        "datagram pattern, period, round trip, working-counter deviations, AL states. Both: the "
        "network the capture shows and the emulator's cycle time for it (wire preset).",
    )
    p.add_argument("path", help="capture file (pcap, pcapng, gzip); - for standard input")
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.add_argument("--csv", metavar="DIR", help="write one CSV file per table into DIR")
    p.add_argument("--plot", metavar="FILE", help="histograms and state timeline (.png or .svg)")
    p.add_argument(
        "--expected-wkc",
        type=int,
        metavar="N",
        help="EtherCAT: the working counter of every process-data datagram "
        "(default: each datagram's steady state)",
    )
    p.add_argument(
        "--pres-timeout-us",
        type=float,
        metavar="US",
        help="EPL: the MN's PRes timeout; a PRes later than this after its PReq is late",
    )
    p.set_defaults(run=run)


def model_cycle_us(config: InferredConfig) -> float | None:
    """The emulator's median cycle time for the inferred network (wire preset), or None when
    the emulator cannot build it."""
    try:
        if config.protocol == "epl":
            cycles = 2 * config.nodes if config.asnd else 2
            r = simulate_epl(config.nodes, config.bytes, WIRE, cycles=cycles, asnd=config.asnd)
        else:
            r = simulate_ecat(
                config.nodes,
                config.bytes,
                WIRE,
                closed_ring=config.topology == "closed",
                layout=config.layout,
                cycles=2,
            )
    except (EmulatorError, ValueError):
        return None
    return r.cycle_us()["median"]


def run(args: argparse.Namespace) -> int:
    """Analyse and report."""
    if args.expected_wkc is not None and not 0 <= args.expected_wkc <= 0xFFFF:
        raise SkinframesError(f"--expected-wkc {args.expected_wkc}: a working counter is 0..65535")
    if args.pres_timeout_us is not None and not 0 <= args.pres_timeout_us < math.inf:
        raise SkinframesError(f"--pres-timeout-us {args.pres_timeout_us}: must be >= 0, finite")
    if args.csv is not None:
        output_folder(args.csv)  # created if its parent exists, as every output folder
    if args.plot is not None and Path(args.plot).suffix.lower() not in (".png", ".svg"):
        raise SkinframesError(f"{args.plot}: the plot is written as .png or .svg")
    timeout_ns = None if args.pres_timeout_us is None else round(args.pres_timeout_us * 1000)
    # a counter of the frames read, on a terminal (a total would cost a pass over the file)
    with progress_bar(None, "frames") as advance:
        if args.path == "-":  # standard input, streamed as decode and check read it
            analysis = analyze_capture(
                open_capture("-"),
                expected_wkc=args.expected_wkc,
                pres_timeout_ns=timeout_ns,
                progress=advance,
            )
        else:
            analysis = analyze_file(
                args.path,
                expected_wkc=args.expected_wkc,
                pres_timeout_ns=timeout_ns,
                progress=advance,
            )
    models = {c.protocol: model_cycle_us(c) for c in analysis.config}
    doc = analysis.to_json()
    doc["path"] = str(args.path)
    doc["model_preset"] = MODEL_PRESET
    for c in doc["config"]:
        c["model_cycle_us"] = models[c["protocol"]]
    if args.csv is not None:
        _write_csv(Path(args.csv), analysis, doc)
    if args.plot is not None:
        _plot(Path(args.plot), analysis)
    if args.json:
        print(json.dumps(doc, indent=2))
    else:
        _print_text(doc, analysis)
    return 0


# --- text -----------------------------------------------------------------------------------------
def _us(ns: float | None) -> str:
    return "-" if ns is None else f"{ns / _NS_PER_US:.3f}"


def _stats_line(s: Summary) -> str:
    if not s.count:
        return "n 0"
    return (
        f"n {s.count}  min {_us(s.min_ns)}  q1 {_us(s.q1_ns)}  median {_us(s.median_ns)}  "
        f"q3 {_us(s.q3_ns)}  max {_us(s.max_ns)}  mean {_us(s.mean_ns)}  std {_us(s.std_ns)} us"
    )


def _limited(lines: list[str], out: list[str]) -> None:
    out += lines[:TEXT_LIST_LIMIT]
    if len(lines) > TEXT_LIST_LIMIT:
        out.append(f"    ... {len(lines) - TEXT_LIST_LIMIT} more (--json or --csv list all)")


def _print_text(doc: dict[str, Any], a: Analysis) -> None:
    counts = ", ".join(f"{k} {v}" for k, v in doc["counts"].items())
    out = [f"{doc['path']}: {a.records} records ({counts})"]
    if a.epl is not None:
        out += _epl_text(a.epl)
    if a.ecat is not None:
        out += _ecat_text(a.ecat)
    for c in doc["config"]:
        model = c["model_cycle_us"]
        measured = c["measured_period_ns"]
        line = (
            f"network ({c['protocol']}): {c['nodes']} nodes x {c['bytes']} bytes, "
            f"{c['layout']}, {c['topology']}{', ASnd' if c['asnd'] else ''}: "
            f"measured period {_us(measured)} us, model ({doc['model_preset']}) "
            f"{'-' if model is None else f'{model:.3f}'} us"
        )
        if model and measured:
            line += f" ({measured / _NS_PER_US / model:.2f} x the model)"
        out.append(line)
    if not doc["config"]:
        out.append("network: no skin network inferred (no uniform cyclic data)")
    sys.stdout.write("\n".join(out) + "\n")


def _epl_text(e: EplAnalysis) -> list[str]:
    counts = ", ".join(f"{k} {v}" for k, v in e.message_counts.items())
    out = [f"EPL: {e.frames} frames ({counts})", f"  SoC period: {_stats_line(e.soc_period)}"]
    for n in sorted(e.responses):
        out.append(
            f"  CN {n:>3}: polled {e.polled.get(n, 0)}, missing "
            f"{e.missing_count.get(n, 0)}, late {e.late_count.get(n, 0)}"
            f", PRes {e.pres_bytes.get(n, '-')} bytes; response {_stats_line(e.responses[n])}"
        )
    if e.pres_timeout_ns is None:
        out.append("  late: no PRes timeout given (--pres-timeout-us); none counted")
    _limited(
        [f"  missing: CN {m.node} polled in frame {m.frame} at {m.time_ns} ns" for m in e.missing],
        out,
    )
    _limited(
        [
            f"  late: CN {m.node} polled in frame {m.frame}, answered after {_us(m.response_ns)} us"
            for m in e.late
        ],
        out,
    )
    _limited(
        [
            f"  NMT state: node {s.node} {s.before or '(first seen)'} -> {s.after} "
            f"(frame {s.frame}, {s.time_ns} ns, {s.source})"
            for s in e.states
        ],
        out,
    )
    if e.asnd_services:
        out.append("  ASnd: " + ", ".join(f"{k} {v}" for k, v in e.asnd_services.items()))
    _limited(
        [
            f"  {ev.kind}: node {ev.node} {ev.detail} (frame {ev.frame}, {ev.time_ns} ns)"
            for ev in e.events
        ],
        out,
    )
    return out


def _ecat_text(e: EcatAnalysis) -> list[str]:
    out = [
        f"EtherCAT: {e.frames} frames ({e.undecodable} undecodable), master ports "
        + ", ".join(e.ports)
    ]
    shown = [(i, p) for i, p in enumerate(e.patterns) if p.cyclic or p.frames > 1]
    for i, p in shown[:TEXT_LIST_LIMIT]:
        out.append(
            f"  pattern {i}{' (cyclic)' if p.cyclic else ''} from {p.port}: {p.frames} sent, "
            f"{p.returned} returned, {len(p.unanswered)} unanswered: {p.text}"
        )
        out.append(f"    period: {_stats_line(p.period)}")
        if p.round_trip.count:
            out.append(f"    round trip: {_stats_line(p.round_trip)}")
        out.append(f"    expected wkc: {list(p.expected_wkc)}")
    if len(shown) > TEXT_LIST_LIMIT:
        out.append(f"  ... {len(shown) - TEXT_LIST_LIMIT} more patterns (--json or --csv)")
    _limited(
        [
            f"  wkc: frame {d.frame} pattern {d.pattern} datagram {d.datagram}: "
            f"{d.wkc}, expected {d.expected}"
            for d in e.wkc_deviations
        ],
        out,
    )
    _limited(
        [
            f"  AL state {s.kind}: {s.target} {s.state} (frame {s.frame}, {s.time_ns} ns)"
            for s in e.al_states
        ],
        out,
    )
    return out


# --- CSV ------------------------------------------------------------------------------------------
_STATS: Final = ("count", "min_ns", "q1_ns", "median_ns", "q3_ns", "mean_ns", "max_ns", "std_ns")


def _table(folder: Path, name: str, header: list[str], rows: list[list[Any]]) -> None:
    with atomic_output(folder / f"{name}.csv", "w") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)


def _write_csv(folder: Path, a: Analysis, doc: dict[str, Any]) -> None:
    """One CSV file per table of the JSON document."""
    cfg = ["protocol", "nodes", "bytes", "layout", "topology", "asnd"]
    cfg += ["measured_period_ns", "model_cycle_us"]
    _table(folder, "config", cfg, [[c[k] for k in cfg] for c in doc["config"]])
    if a.epl is not None:
        e = doc["epl"]
        _table(
            folder,
            "epl_soc_period",
            list(_STATS),
            [[e["soc_period"][k] for k in _STATS]],
        )
        head = ["node", "polled", "pres_bytes", "missing", "late", "unexpected"]
        _table(
            folder,
            "epl_nodes",
            head + [f"response_{k}" for k in _STATS],
            [[n[k] for k in head] + [n["response"][k] for k in _STATS] for n in e["nodes"]],
        )
        for name, key, cols in (
            ("epl_missing", "missing", ["node", "frame", "time_ns"]),
            ("epl_late", "late", ["node", "frame", "time_ns", "response_ns"]),
            ("epl_nmt_states", "nmt_states", ["node", "frame", "time_ns", "before", "after"]),
            ("epl_events", "events", ["frame", "time_ns", "node", "kind", "detail"]),
        ):
            _table(folder, name, cols, [[r[k] for k in cols] for r in e[key]])
        _table(folder, "epl_asnd_services", ["service", "count"], list(e["asnd_services"].items()))
    if a.ecat is not None:
        e = doc["ecat"]
        head = ["pattern", "datagrams", "cyclic", "port", "frames", "returned"]
        _table(
            folder,
            "ecat_patterns",
            head
            + ["unanswered"]
            + [f"period_{k}" for k in _STATS]
            + [f"round_trip_{k}" for k in _STATS],
            [
                [p[k] for k in head]
                + [len(p["unanswered"])]
                + [p["period"][k] for k in _STATS]
                + [p["round_trip"][k] for k in _STATS]
                for p in e["patterns"]
            ],
        )
        cols = ["frame", "time_ns", "pattern", "datagram", "wkc", "expected"]
        _table(
            folder, "ecat_wkc_deviations", cols, [[d[k] for k in cols] for d in e["wkc_deviations"]]
        )
        cols = ["frame", "time_ns", "kind", "target", "state", "value"]
        _table(folder, "ecat_al_states", cols, [[s[k] for k in cols] for s in e["al_states"]])


# --- picture --------------------------------------------------------------------------------------
def _plot(out: Path, a: Analysis) -> None:
    """Period and response-time histograms and a state timeline, one row of three panels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_period, ax_response, ax_state) = plt.subplots(1, 3, figsize=(16, 4.5))
    if a.epl is not None and len(a.epl.soc_period_ns):
        ax_period.hist(a.epl.soc_period_ns / _NS_PER_US, bins=50)
        ax_period.set_title("EPL SoC period")
        for n in sorted(a.epl.response_ns):
            if len(a.epl.response_ns[n]):
                ax_response.hist(
                    a.epl.response_ns[n] / _NS_PER_US, bins=50, alpha=0.6, label=f"CN {n}"
                )
        ax_response.set_title("PReq -> PRes response time")
        if len(a.epl.response_ns) <= 10:
            ax_response.legend(fontsize="small")
        nodes = sorted({s.node for s in a.epl.states})
        order = {name: i for i, name in enumerate(NmtState.__members__)}  # DS 301 order
        names = sorted({s.after for s in a.epl.states}, key=lambda n: (order.get(n, 99), n))
        for node in nodes:
            points = [(s.time_ns, names.index(s.after)) for s in a.epl.states if s.node == node]
            xs = [(t - a.epl.states[0].time_ns) / 1e9 for t, _ in points]
            ax_state.step(xs, [v for _, v in points], where="post", label=f"node {node}")
        ax_state.set_yticks(range(len(names)), names, fontsize="small")
        ax_state.set_title("NMT state (step at each change)")
        ax_state.set_xlabel("s from the first state seen")
    elif a.ecat is not None:
        cyclic = [p for p in a.ecat.patterns if p.cyclic and len(p.period_ns)] or [
            p for p in a.ecat.patterns if len(p.period_ns)
        ]
        for i, p in enumerate(cyclic[:5]):
            ax_period.hist(p.period_ns / _NS_PER_US, bins=50, alpha=0.6, label=f"pattern {i}")
            if len(p.round_trip_ns):
                ax_response.hist(p.round_trip_ns / _NS_PER_US, bins=50, alpha=0.6)
        ax_period.set_title("EtherCAT cyclic-frame period")
        if cyclic:
            ax_period.legend(fontsize="small")
        ax_response.set_title("EtherCAT round trip")
        states = [s for s in a.ecat.al_states if s.kind == "reported"]
        by_value = {s.state: s.value for s in states}  # INIT < PREOP < SAFEOP < OP, errors after
        names = sorted(by_value, key=lambda n: (by_value[n] & 0x0F, by_value[n]))
        targets = sorted({s.target for s in states})
        t0 = states[0].time_ns if states else 0
        for target in targets:
            points = [(s.time_ns, names.index(s.state)) for s in states if s.target == target]
            ax_state.step(
                [(t - t0) / 1e9 for t, _ in points],
                [v for _, v in points],
                where="post",
                label=target,
            )
        ax_state.set_yticks(range(len(names)), names, fontsize="small")
        ax_state.set_title("AL state reported")
        ax_state.set_xlabel("s from the first state seen")
    for ax in (ax_period, ax_response):
        ax.set_xlabel("us")
        ax.set_ylabel("frames")
    if ax_state.get_legend_handles_labels()[0]:
        ax_state.legend(fontsize="small")
    fig.tight_layout()
    save_figure(fig, out, dpi=100)
