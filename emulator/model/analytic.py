"""The paper's closed-form cycle-time model, eqs. (3)-(19), vectorised with numpy.

Symbols follow the paper; every function takes ``n`` (nodes) and ``data`` (bytes per node) as
scalars or arrays and returns microseconds. With :data:`emulator.model.params.PAPER` the functions
reproduce all 96 cells of Tables I-III (tests/emulator/test_analytic.py). Where the printed
equations and the tables disagree, the tables win and the function says so (docs/paper-notes.md).
"""

from __future__ import annotations

from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.model.names import closed_ring_flag
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_US
from skinframes import ethercat, ethernet, powerlink

__all__ = [
    "d_nk",
    "ecat_cycle_us",
    "epl_cycle_us",
    "max_tgram",
    "n_fr",
    "t_ecat_ov",
    "t_epl",
    "t_is",
    "t_pad",
    "t_rq",
    "t_rs",
    "t_soa",
    "t_st",
]

Num = npt.ArrayLike
Arr = npt.NDArray[np.float64]

E_OV: Final = ethernet.OVERHEAD_BYTES  # 26: preamble 8 + MACs 12 + EtherType 2 + CRC 4
MIN_PL: Final = ethernet.MIN_PAYLOAD_BYTES  # 46
H_PDO: Final = powerlink.PDO_HEADER_BYTES  # 10: H_PReq = H_PRes
P_SOC: Final = MIN_PL  # the SoC occupies the 46-byte minimum payload
H_SOA: Final = MIN_PL  # "46byte header size of the SoA message" (eq. 10)
H_ASND: Final = 5  # eq. (11); on the wire the ASnd header is 4 bytes (frames.md 1.2)
D_ETH_MAX_PL: Final = ethernet.MAX_PAYLOAD_BYTES  # 1500
D_ECAT_HD: Final = ethercat.FRAME_HEADER_BYTES  # 2
D_TGRAM_HD: Final = ethercat.DATAGRAM_HEADER_BYTES  # 10
D_WC: Final = ethercat.WKC_BYTES  # 2
D_IFG: Final = ethernet.IFG_BYTES  # 12


def _us(p: TimingParams, ps: int) -> float:
    return ps / PS_PER_US


def _b(p: TimingParams) -> float:
    """Byte rate b in bytes/us (12.5 at 100 Mbit/s)."""
    return PS_PER_US / p.byte_ps


def _f(x: object) -> Arr:
    return np.asarray(x, dtype=np.float64)


def _pad(header: Num, data: Num) -> Arr:
    """pad = bytes that fill header + data up to the 46-byte minimum payload."""
    return _f(np.maximum(0, MIN_PL - (np.asarray(header) + np.asarray(data))))


# --- Ethernet POWERLINK, eqs. (3)-(11) -------------------------------------------------------------
def t_st(p: TimingParams) -> float:
    """Eq. (4): T_st = (P_SoC + E_ov) / b + T_IFG, the start period (6.72 us)."""
    return (P_SOC + E_OV) / _b(p) + _us(p, p.ifg_ps)


def t_rq(n: Num, p: TimingParams, data: Num = 0) -> Arr:
    """Eq. (6): T_rq = n (H_PReq + data + pad + E_ov) / b; the MN sends no data (assumption ii)."""
    return _f(np.asarray(n) * (H_PDO + np.asarray(data) + _pad(H_PDO, data) + E_OV) / _b(p))


def t_rs(n: Num, data: Num, p: TimingParams) -> Arr:
    """Eq. (7): T_rs = n (H_PRes + data + pad + E_ov) / b."""
    return _f(np.asarray(n) * (H_PDO + np.asarray(data) + _pad(H_PDO, data) + E_OV) / _b(p))


def d_nk(n: Num, p: TimingParams) -> Arr:
    """Eq. (8): D_nk = 2n (D_hub + D_medium) + 2 sum_{i=1..n} i (D_hub + D_medium).

    The sum is n(n+1)/2, so D_nk = (2n + n(n+1)) (D_hub + D_medium): quadratic in n, which is
    why the paper's Fig. 9 looks "almost exponential".
    """
    k = _f(n)
    return _f((2 * k + k * (k + 1)) * _us(p, p.hop_ps))


def t_is(n: Num, data: Num, p: TimingParams) -> Arr:
    """Eq. (5): T_is = T_rq + T_rs + D_mn + D_cn + D_nk.

    Table I charges D_mn and D_cn once per polled CN (n x 2 us), not once per cycle as eq. (5)
    is printed; this function follows the table.
    """
    n_arr = np.asarray(n, dtype=np.float64)
    per_cn = n_arr * _us(p, p.epl_mn_delay_ps + p.epl_cn_delay_ps)
    return t_rq(n, p) + t_rs(n, data, p) + per_cn + d_nk(n, p)


def t_soa(p: TimingParams) -> float:
    """Eq. (10): T_SoA = (H_SoA + E_ov) / b + T_IFG (6.72 us)."""
    return (H_SOA + E_OV) / _b(p) + _us(p, p.ifg_ps)


def t_asnd(data: Num, p: TimingParams) -> Arr:
    """Eq. (11): T_ASnd = (H_ASnd + data + pad + E_ov) / b."""
    return _f((H_ASND + np.asarray(data) + _pad(H_ASND, data) + E_OV) / _b(p))


def t_epl(n: Num, data: Num, p: TimingParams, asnd_data: Num | None = None) -> Arr:
    """Eq. (3): T_epl = T_st + T_is + T_as + T_id, with T_as = T_SoA (+ T_ASnd) (eq. 9).

    Assumption (iii), no asynchronous frames, is the default (``asnd_data=None``); the idle
    period T_id is ``p.epl_cycle_idle_ps`` (one IFG in the paper preset).
    """
    t_as = t_soa(p) + (0.0 if asnd_data is None else t_asnd(asnd_data, p))
    return t_st(p) + t_is(n, data, p) + t_as + _us(p, p.epl_cycle_idle_ps)


def epl_cycle_us(n: Num, data: Num, p: TimingParams) -> Arr:
    """EPL cycle time in us for n CNs of ``data`` bytes (Table I)."""
    return np.asarray(t_epl(n, data, p), dtype=np.float64)


# --- EtherCAT, eqs. (12)-(19) ----------------------------------------------------------------------
def max_tgram(data: Num) -> npt.NDArray[np.int64]:
    """Eq. (15): floor((D_eth_max_payload - D_ecat_hd) / (D_data + D_tgram_hd + D_wc))."""
    return (D_ETH_MAX_PL - D_ECAT_HD) // (np.asarray(data, dtype=np.int64) + D_TGRAM_HD + D_WC)


def n_fr(n: Num, data: Num) -> npt.NDArray[np.int64]:
    """Eq. (14) as the tables use it: n_fr = ceil(n / max_tgram).

    The paper prints ceil(max_tgram / n), which is 1 for every table cell and cannot give the
    tables' values (docs/paper-notes.md).
    """
    return -(-np.asarray(n, dtype=np.int64) // max_tgram(data))


def t_eth(p: TimingParams) -> float:
    """Eq. (16): T_eth = (D_ethernet + D_IFG) / b: 26 + 12 bytes per frame (3.04 us)."""
    return (E_OV + D_IFG) / _b(p)


def t_ecat_ov(n: Num, data: Num, p: TimingParams) -> Arr:
    """Eq. (17): T_ecat_ov = (n_fr D_ecat_hd + n (D_tgram_hd + D_wc)) / b."""
    return _f((n_fr(n, data) * D_ECAT_HD + np.asarray(n) * (D_TGRAM_HD + D_WC)) / _b(p))


def t_pad(n: Num, data: Num, p: TimingParams) -> Arr:
    """Eqs. (18)-(19): padding of the last frame, when it holds n mod max_tgram datagrams and
    those occupy fewer than 46 bytes."""
    rest = np.asarray(n, dtype=np.int64) % max_tgram(data)
    d_ecat = D_ECAT_HD + (D_TGRAM_HD + D_WC + np.asarray(data)) * rest
    return np.where((rest != 0) & (d_ecat < MIN_PL), (MIN_PL - d_ecat) / _b(p), 0.0)


def t_ecat_fwd(p: TimingParams, closed_ring: bool) -> float:
    """T_ecat_fwd of eq. (12): both passes through each ESC in the open ring, one in the closed."""
    if closed_ring:
        return _us(p, p.ecat_processing_ps)
    return _us(p, p.ecat_processing_ps + p.ecat_forwarding_ps)


def ecat_cycle_us(
    n: Num,
    data: Num,
    p: TimingParams,
    closed_ring: bool | None = None,
    *,
    redundant: bool | None = None,
) -> Arr:
    """Eq. (12): T_ecat = n (T_fwd + T_data) + N_cables T_medium + n_fr T_eth + T_ecat_ov + T_pad.

    N_cables is 2n in the open ring (every cable crossed out and back) and n + 1 in the closed
    ring (Tables II and III). ``redundant`` is the old name of ``closed_ring`` (the paper's word).
    """
    ring = closed_ring_flag(closed_ring, redundant)
    n_arr = np.asarray(n, dtype=np.float64)
    t_data = np.asarray(data) / _b(p)  # eq. (13)
    cables = n_arr + 1 if ring else 2 * n_arr
    return np.asarray(
        n_arr * (t_ecat_fwd(p, ring) + t_data)
        + cables * _us(p, p.cable_ps)
        + n_fr(n, data) * t_eth(p)
        + t_ecat_ov(n, data, p)
        + t_pad(n, data, p),
        dtype=np.float64,
    )
