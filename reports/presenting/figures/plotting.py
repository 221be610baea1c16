"""What every figure shares: matplotlib without a display, the palette, saving."""

from __future__ import annotations

import io
import os
from types import ModuleType
from typing import TYPE_CHECKING

from volcaustics.infra.storage import atomic_path

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# Okabe & Ito's colour-blind-safe palette
OKABE_ITO = ("#E69F00", "#56B4E9", "#009E73", "#D55E00", "#0072B2", "#CC79A7", "#F0E442", "#000000")


def pyplot() -> ModuleType:
    """matplotlib.pyplot on the Agg backend (no display; imported on first use: slow)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Figure, folder: str, name: str) -> list:
    """``folder``/``name``.png and .svg, each written whole; the figure is closed."""
    os.makedirs(folder, exist_ok=True)
    paths = []
    for ext in ("png", "svg"):
        path = os.path.join(folder, f"{name}.{ext}")
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=ext, dpi=110, bbox_inches="tight")
        paths.append(path)
    pyplot().close(fig)
    return paths


def png_bytes(fig: Figure, dpi: int = 100) -> bytes:
    """The figure as PNG bytes; the figure is closed."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, bbox_inches="tight")
    pyplot().close(fig)
    return buffer.getvalue()


def remove_stale_figures(folder: str, keep: list) -> None:
    """Remove the figures (.png, .svg) in ``folder`` that this run did not draw (an
    earlier ``--sweep``'s, or all of them without one), and the folder when nothing is
    left; other files are left alone."""
    if not os.path.isdir(folder):
        return
    kept = {os.path.abspath(p) for p in keep}
    for name in os.listdir(folder):
        path = os.path.join(folder, name)
        if name.endswith((".png", ".svg")) and os.path.abspath(path) not in kept and os.path.isfile(path):
            os.unlink(path)
    if not os.listdir(folder):
        os.rmdir(folder)
