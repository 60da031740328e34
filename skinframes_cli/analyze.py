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
from collections import Counter
from pathlib import Path
from typing import Any, Final

import numpy as np

from emulator import WIRE, EmulatorError, simulate_ecat, simulate_epl
from emulator.model.params import PRESETS, TimingParams, preset, with_cn_response
from skinframes.analysis import Analysis, InferredConfig, Summary, analyze_capture, analyze_file
from skinframes.analysis.ecat import EcatAnalysis
from skinframes.analysis.epl import EplAnalysis
from skinframes.atomic_file import atomic_output, output_folder
from skinframes.errors import SkinframesError
from skinframes.powerlink import NmtState
from skinframes_cli.figure import save_figure
from skinframes_cli.live import add_live, capture_input, first_frames, is_live, report_records
from skinframes_cli.options import file_output, in_path
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
        "network the capture shows and the emulator's cycle time for it (--preset, wire by "
        "default).",
    )
    p.add_argument(
        "path",
        nargs="?",
        type=in_path,
        metavar="PATH",
        help="capture file (pcap, pcapng, gzip); - for standard input",
    )
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.add_argument(
        "--csv", type=file_output, metavar="DIR", help="write one CSV file per table into DIR"
    )
    p.add_argument(
        "--plot",
        type=file_output,
        metavar="FILE",
        help="histograms and state timeline (.png or .svg)",
    )
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
    p.add_argument(
        "--preset",
        choices=list(PRESETS),
        default=MODEL_PRESET,
        help=f"the model's timing constants (default: {MODEL_PRESET}; paper for a capture "
        "simulate made with its default)",
    )
    add_live(p)
    p.set_defaults(run=run)


def model_cycle_us(
    config: InferredConfig, cn_response_ps: int | None = None, params: TimingParams = WIRE
) -> float | None:
    """The emulator's median cycle time for the inferred network (``params``, the wire preset
    by default; EPL with each CN answering in ``cn_response_ps`` when given,
    :func:`emulator.model.params.with_cn_response`), or None when the emulator cannot build
    it."""
    try:
        if config.protocol == "epl":
            cycles = 2 * config.nodes if config.asnd else 2
            epl = with_cn_response(params, cn_response_ps)
            r = simulate_epl(config.nodes, config.bytes, epl, cycles=cycles, asnd=config.asnd)
        else:
            r = simulate_ecat(
                config.nodes,
                config.bytes,
                params,
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
    live = is_live(args)
    if live:
        with capture_input(args, args.count) as capture:
            analysis = analyze_capture(
                capture, expected_wkc=args.expected_wkc, pres_timeout_ns=timeout_ns
            )
        source = capture.path
    else:
        analysis = _analyze_file(args, timeout_ns)
        source = str(args.path)
    params = preset(args.preset)
    models = {c.protocol: model_cycle_us(c, params=params) for c in analysis.config}
    doc = analysis.to_json()
    doc["path"] = source
    doc["model_preset"] = args.preset
    for c in doc["config"]:
        c["model_cycle_us"] = models[c["protocol"]]
    if analysis.epl is not None and any(c["protocol"] == "epl" for c in doc["config"]):
        _model_with_measured_cn(doc, analysis, params)
    if args.csv is not None:
        _write_csv(Path(args.csv), analysis, doc)
    if args.plot is not None:
        _plot(Path(args.plot), analysis)
    if args.json:
        print(json.dumps(doc, indent=2))
    else:
        _print_text(doc, analysis)
    if analysis.skipped:  # as decode reports them
        n = analysis.records
        report_records(n + len(analysis.skipped), n, analysis.skipped)
    return 0


def _analyze_file(args: argparse.Namespace, timeout_ns: int | None) -> Analysis:
    # a counter of the frames read, on a terminal (a total would cost a pass over the file)
    with progress_bar(None, "frames") as advance:
        if args.path == "-" or args.count is not None:  # stdin, streamed; or the first N
            analysis = analyze_capture(
                first_frames(args),
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
    return analysis


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


def _model_with_measured_cn(doc: dict[str, Any], a: Analysis, params: TimingParams) -> None:
    """The EPL network's model beside what it predicts (issue 40): the cycle's used part (SoC to
    its last frame), and the model again with the CNs' own answer, the median PReq -> PRes time
    of all polls, as D_CN (``cn_response_median_us``, ``model_cycle_measured_cn_us``; the
    capture's PReq -> PRes includes the two frames' wire times, so the model is an upper bound
    there)."""
    assert a.epl is not None
    times = [t for t in a.epl.response_ns.values() if len(t)]
    median_ns = float(np.median(np.concatenate(times))) if times else None
    for c, config in zip(doc["config"], a.config, strict=True):
        if c["protocol"] != "epl":
            continue
        c["cn_response_median_us"] = None if median_ns is None else median_ns / _NS_PER_US
        c["model_cycle_measured_cn_us"] = (
            None if not median_ns else model_cycle_us(config, round(median_ns * 1000), params)
        )


def _print_text(doc: dict[str, Any], a: Analysis) -> None:
    counts = ", ".join(f"{k} {v}" for k, v in doc["counts"].items())
    out = [f"{doc['path']}: {a.records} records ({counts})"]
    if a.skipped:
        out.append(
            f"skipped: {len(a.skipped)} records could not be read, not analysed: frames "
            f"{_ranges([s.frame for s in a.skipped])} (the reasons on stderr)"
        )
    if a.epl is not None:
        out += _epl_text(a.epl)
    if a.ecat is not None:
        out += _ecat_text(a.ecat)
    for c in doc["config"]:
        model = c["model_cycle_us"]
        measured = c["measured_period_ns"]
        if c["protocol"] == "epl" and a.epl is not None and a.epl.used.count:
            out.append(_epl_network_line(c, a.epl, doc["model_preset"]))
            continue
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


def _epl_network_line(c: dict[str, Any], e: EplAnalysis, preset: str) -> str:
    """The EPL network with the model beside what it predicts: the part of the cycle used (SoC
    to its last frame), not the configured cycle length, which the MN sets."""
    model, measured_cn = c["model_cycle_us"], c.get("model_cycle_measured_cn_us")
    line = (
        f"network (epl): {c['nodes']} nodes x {c['bytes']} bytes, {c['layout']}, "
        f"{c['topology']}{', ASnd' if c['asnd'] else ''}: cycle used (SoC to its last frame) "
        f"median {_us(e.used.median_ns)} us of the {_us(c['measured_period_ns'])} us period; model "
        f"({preset}) {'-' if model is None else f'{model:.3f}'} us with 1 us CNs"
    )
    if measured_cn is not None:
        line += (
            f", {measured_cn:.3f} us with the CNs' measured "
            f"{c['cn_response_median_us']:.3f} us (median PReq -> PRes)"
        )
    return line


def _epl_text(e: EplAnalysis) -> list[str]:
    counts = ", ".join(f"{k} {v}" for k, v in e.message_counts.items())
    out = [f"EPL: {e.frames} frames ({counts})", f"  SoC period: {_stats_line(e.soc_period)}"]
    if e.used.count:
        out.append(
            "  cycle phases (medians): isochronous (SoC -> SoA) "
            f"{_us(e.isochronous.median_ns)} us, asynchronous (SoA -> next SoC) "
            f"{_us(e.asynchronous.median_ns)} us, headroom (last frame -> next SoC) "
            f"{_us(e.headroom.median_ns)} us"
        )
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


def pattern_order(e: EcatAnalysis) -> tuple[list[int], list[int], list[int]]:
    """The patterns' numbers (as in JSON, CSV and the plot) in the order the text lists them:
    the cyclic ones (process data), then the others sent more than once, each busiest first;
    and apart, the patterns of one frame, which the text summarises in one line."""

    def busiest(i: int) -> tuple[int, int]:
        return (-e.patterns[i].frames, i)

    cyclic = sorted((i for i, p in enumerate(e.patterns) if p.cyclic), key=busiest)
    repeated = sorted(
        (i for i, p in enumerate(e.patterns) if not p.cyclic and p.frames > 1), key=busiest
    )
    once = [i for i, p in enumerate(e.patterns) if not p.cyclic and p.frames <= 1]
    return cyclic, repeated, once


def _ecat_text(e: EcatAnalysis) -> list[str]:
    cyclic, repeated, once = pattern_order(e)
    out = [
        f"EtherCAT: {e.frames} frames ({e.undecodable} undecodable), master ports "
        + ", ".join(e.ports)
        + f"; {len(e.patterns)} patterns: {len(cyclic)} cyclic, {len(repeated)} repeated, "
        f"{len(once)} of one frame"
    ]
    shown = [*cyclic, *repeated]
    for i in shown[:TEXT_LIST_LIMIT]:
        p = e.patterns[i]
        out.append(
            f"  pattern {i}{' (cyclic)' if p.cyclic else ''} from {p.port}: {p.frames} sent, "
            f"{p.returned} returned, {len(p.unanswered)} unanswered: {p.text}"
        )
        out.append(f"    period: {_stats_line(p.period)}")
        if p.round_trip.count:
            out.append(f"    round trip: {_stats_line(p.round_trip)}")
        out.append(f"    expected wkc: {list(p.expected_wkc)}")
    if len(shown) > TEXT_LIST_LIMIT:
        out.append(
            f"  ... {len(shown) - TEXT_LIST_LIMIT} more repeated patterns, "
            f"{sum(e.patterns[i].frames for i in shown[TEXT_LIST_LIMIT:])} frames "
            "(--json or --csv)"
        )
    if once:
        commands = Counter(e.patterns[i].text.split(" ", 1)[0] for i in once)
        kinds = ", ".join(f"{cmd} {n}" for cmd, n in commands.most_common())
        answered = sum(e.patterns[i].returned for i in once)
        out.append(
            f"  {len(once)} patterns of one frame each (first datagram {kinds}), {answered} "
            f"returned: patterns {_ranges(once)} (--json or --csv)"
        )
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


def _ranges(numbers: list[int]) -> str:
    """``3..5, 9, 12..40``: sorted numbers as runs."""
    runs: list[list[int]] = []
    for n in sorted(numbers):
        if runs and n == runs[-1][1] + 1:
            runs[-1][1] = n
        else:
            runs.append([n, n])
    return ", ".join(f"{a}..{b}" if b > a else f"{a}" for a, b in runs)


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
LEGEND_MAX: Final = 10  # curves drawn one per node/pattern up to this many; beyond, a summary


def _plot(out: Path, a: Analysis) -> None:
    """Period and response-time panels and, when the capture shows states, a state timeline.

    Readable at 160 nodes: up to :data:`LEGEND_MAX` nodes one curve each, more as a summary (the
    response time per node as median and quartiles, the number of nodes in each state over
    time); legends beside the axes, never over them; plain time axes (no offset), integer
    counts; patterns named by their numbers in the JSON.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    states = _state_series(a)
    panels = 3 if states else 2
    fig, axes = plt.subplots(1, panels, figsize=(6 * panels, 4.5), layout="constrained")
    ax_period, ax_response = axes[0], axes[1]
    if a.epl is not None and len(a.epl.soc_period_ns):
        ax_period.hist(a.epl.soc_period_ns / _NS_PER_US, bins=50)
        ax_period.set_title("EPL SoC period")
        nodes = [n for n in sorted(a.epl.response_ns) if len(a.epl.response_ns[n])]
        if len(nodes) <= LEGEND_MAX:
            for n in nodes:
                ax_response.hist(
                    a.epl.response_ns[n] / _NS_PER_US, bins=50, alpha=0.6, label=f"CN {n}"
                )
            _counts(ax_response, "frames")
            _legend_beside(ax_response)
        else:
            _per_node(ax_response, nodes, [a.epl.response_ns[n] / _NS_PER_US for n in nodes])
        ax_response.set_title("PReq -> PRes response time")
    elif a.ecat is not None:
        cyclic, repeated, _ = pattern_order(a.ecat)
        numbers = [i for i in cyclic if len(a.ecat.patterns[i].period_ns)] or [
            i for i in repeated if len(a.ecat.patterns[i].period_ns)
        ]
        for i in numbers[:5]:
            p = a.ecat.patterns[i]
            ax_period.hist(p.period_ns / _NS_PER_US, bins=50, alpha=0.6, label=f"pattern {i}")
            if len(p.round_trip_ns):
                ax_response.hist(
                    p.round_trip_ns / _NS_PER_US, bins=50, alpha=0.6, label=f"pattern {i}"
                )
        kind = "cyclic" if cyclic else "repeated"
        drawn = f" ({min(len(numbers), 5)} of {len(numbers)} patterns)" if len(numbers) > 5 else ""
        ax_period.set_title(f"EtherCAT {kind}-frame period{drawn}")
        ax_response.set_title("EtherCAT round trip")
        for ax in (ax_period, ax_response):
            _counts(ax, "frames")
            _legend_beside(ax)
    if ax_period.has_data():
        _counts(ax_period, "frames")
    if states:
        title, series = states
        ax_state = axes[2]
        names = sorted({v for _, pts in series for _, v in pts}, key=lambda n: _state_order(a, n))
        t0 = min(t for _, pts in series for t, _ in pts)
        if len(series) <= LEGEND_MAX:
            for label, pts in series:
                ax_state.step(
                    [(t - t0) / 1e9 for t, _ in pts],
                    [names.index(v) for _, v in pts],
                    where="post",
                    label=label,
                )
            ax_state.set_yticks(range(len(names)), names, fontsize="small")
            ax_state.set_title(title)
        else:  # one curve per state: how many nodes are in it, over time
            times, counts = _nodes_in_states(series, names)
            for name in names:
                ax_state.step([(t - t0) / 1e9 for t in times], counts[name], where="post",
                              label=name)  # fmt: skip
            ax_state.yaxis.set_major_locator(MaxNLocator(integer=True))
            ax_state.set_ylabel("nodes")
            ax_state.set_title(f"{title}: nodes in each state ({len(series)} nodes)")
        ax_state.set_xlabel("s from the first state seen")
        ax_state.ticklabel_format(axis="x", useOffset=False, style="plain")
        _legend_beside(ax_state)
    save_figure(fig, out, dpi=100)


def _counts(ax: Any, what: str) -> None:
    """A histogram's axes: plain microseconds (no offset), integer counts."""
    from matplotlib.ticker import MaxNLocator

    ax.set_xlabel("us")
    ax.set_ylabel(what)
    ax.ticklabel_format(axis="x", useOffset=False, style="plain")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))


def _legend_beside(ax: Any) -> None:
    """A legend below the axes (never over the data), when there is something to name."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(
            handles, labels, fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.18),
            ncols=min(len(labels), 3), frameon=False,
        )  # fmt: skip


def _per_node(ax: Any, nodes: list[int], values_us: list[Any]) -> None:
    """Median and quartiles of each node's times, against the node (many nodes)."""
    import numpy as np

    q1, med, q3 = (np.array([np.percentile(v, q) for v in values_us]) for q in (25, 50, 75))
    ax.errorbar(nodes, med, yerr=[med - q1, q3 - med], fmt=".", markersize=3, elinewidth=0.8)
    ax.set_xlabel("CN node id")
    ax.set_ylabel("us (median, quartiles)")
    ax.ticklabel_format(axis="y", useOffset=False, style="plain")


def _state_order(a: Analysis, name: str) -> tuple[int, str]:
    """EPL: DS 301's order of NMT states; EtherCAT: INIT < PREOP < SAFEOP < OP, errors after."""
    if a.epl is not None and a.epl.states:
        order = {n: i for i, n in enumerate(NmtState.__members__)}
        return (order.get(name, 99), name)
    values = {s.state: s.value for s in a.ecat.al_states} if a.ecat is not None else {}
    v = values.get(name, 0xFF)
    return (v & 0x0F, name) if v != 0xFF else (99, name)


def _state_series(a: Analysis) -> tuple[str, list[tuple[str, list[tuple[int, str]]]]] | None:
    """(title, [(node label, [(time_ns, state)])]) of the states the capture shows, or None."""
    if a.epl is not None and a.epl.states:
        nodes = sorted({s.node for s in a.epl.states})
        return "NMT state", [
            (f"node {n}", [(s.time_ns, s.after) for s in a.epl.states if s.node == n])
            for n in nodes
        ]
    if a.epl is None and a.ecat is not None:
        reported = [s for s in a.ecat.al_states if s.kind == "reported"]
        if reported:
            targets = sorted({s.target for s in reported})
            return "AL state reported", [
                (t, [(s.time_ns, s.state) for s in reported if s.target == t]) for t in targets
            ]
    return None


def _nodes_in_states(
    series: list[tuple[str, list[tuple[int, str]]]], names: list[str]
) -> tuple[list[int], dict[str, list[int]]]:
    """At each change, how many nodes are in each state (a node counts from its first state)."""
    events = sorted((t, i, v) for i, (_, pts) in enumerate(series) for t, v in pts)
    now: dict[int, str] = {}
    times: list[int] = []
    counts: dict[str, list[int]] = {n: [] for n in names}
    for t, i, v in events:
        now[i] = v
        if times and times[-1] == t:
            for n in names:
                counts[n].pop()
            times.pop()
        times.append(t)
        tally = Counter(now.values())
        for n in names:
            counts[n].append(tally.get(n, 0))
    return times, counts
