"""The paper's Tables I-III as printed (cycle time in us), for showing differences in reports.

Transcribed from ../shared/paper.md. The tests keep their own transcription
(tests/data/paper_tables.py) so that they do not check the model against this copy.
"""

from __future__ import annotations

from typing import Final

from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL, table_name
from skinframes import powerlink

BYTES: Final = (2, 32, 128, 256)
NODES: Final = (130, 140, 150, 160, 170, 180, 190, 200)
# The x-axis of Figs. 9-11: the paper's "maximum of 240 nodes" (II-A); EPL stops at its 239 CNs
# (node 240 is the MN).
PAPER_MAX_NODES: Final = 240
FIGURE_MAX_NODES: Final = {
    EPL: powerlink.MAX_CN_NODE_ID,
    ECAT: PAPER_MAX_NODES,
    ECAT_CLOSED_RING: PAPER_MAX_NODES,
}
_ROWS: Final = {
    EPL: (
        (6967.65, 6967.65, 7924.45, 9255.65),
        (7923.21, 7923.21, 8953.61, 10387.21),
        (8938.88, 8938.88, 10042.88, 11578.88),
        (10014.64, 10014.64, 11192.24, 12830.64),
        (11150.51, 11150.51, 12401.71, 14142.51),
        (12346.47, 12346.47, 13671.27, 15514.47),
        (13602.54, 13602.54, 15000.94, 16946.54),
        (14918.70, 14918.70, 16390.70, 18438.70),
    ),
    ECAT: (
        (327.63, 646.03, 1673.23, 3046.03),
        (352.34, 697.94, 1801.94, 3280.34),
        (377.05, 746.65, 1930.65, 3514.65),
        (401.76, 795.36, 2059.36, 3748.96),
        (426.47, 844.07, 2188.07, 3983.27),
        (451.18, 895.98, 2316.78, 4217.58),
        (475.89, 944.69, 2445.49, 4451.89),
        (500.60, 993.40, 2574.20, 4686.20),
    ),
    ECAT_CLOSED_RING: (
        (239.82, 558.22, 1585.42, 2958.22),
        (257.77, 603.37, 1707.37, 3185.77),
        (275.73, 645.33, 1829.33, 3413.33),
        (293.68, 687.28, 1951.28, 3640.88),
        (311.64, 729.24, 2073.24, 3868.44),
        (329.59, 774.39, 2195.19, 4095.99),
        (347.55, 816.35, 2317.15, 4323.55),
        (365.50, 858.30, 2439.10, 4551.10),
    ),
}


def paper_value(table: str, nodes: int, data_bytes: int) -> float | None:
    """The printed cell of Table I ("epl"), II ("ecat") or III ("ecat_closed_ring", old name
    "ecat_redundant"), if any.

    Raises:
        PresetError: no table has this name.
    """
    table = table_name(table)
    if nodes not in NODES or data_bytes not in BYTES:
        return None
    return _ROWS[table][NODES.index(nodes)][BYTES.index(data_bytes)]
