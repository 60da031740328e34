"""Pictures the command line draws: written atomically, format from the file's suffix."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from skinframes.atomic_file import atomic_path

__all__ = ["save_figure"]


def save_figure(fig: Any, out: Path, dpi: int = 110) -> None:
    """Write matplotlib ``fig`` to ``out`` (PNG, SVG, ... by the suffix; PNG without one)
    through :func:`skinframes.atomic_file.atomic_path`, then close it, also on an error."""
    import matplotlib.pyplot as plt

    try:
        with atomic_path(out) as tmp:
            fig.savefig(tmp, dpi=dpi, format=out.suffix.lstrip(".").lower() or "png")
    finally:
        plt.close(fig)
