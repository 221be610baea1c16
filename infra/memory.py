"""What one command may allocate, and the images that fit in it: one source for the
approximation, the reference and the measurement.

The budget is half of this machine's physical memory: llvmpipe's GL buffers live
there, and so do the reference's film and every image a measurement holds on any
machine. An image's cost is its pixels times bytes per pixel, measured per consumer
(``bench/image_memory.py``; figures in docs/decisions.md "Image sizes against memory").
"""

from __future__ import annotations

import math
import os


def memory_budget() -> int:
    """Half of this machine's physical memory, in bytes."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (ValueError, OSError, AttributeError):  # not a POSIX sysconf: do not guess
        return 1 << 62


def image_fits(width: int, height: int, bytes_per_pixel: float, what: str) -> str | None:
    """None when ``what`` (e.g. "the approximation's image buffers") at width × height
    fits :func:`memory_budget`; else the reason, naming the need, the limit and the
    largest image of this aspect that fits."""
    need, budget = width * height * bytes_per_pixel, memory_budget()
    if need <= budget:
        return None
    scale = math.sqrt(budget / need)
    fits_w, fits_h = max(1, int(width * scale)), max(1, int(height * scale))
    return (f"width × height = {width} × {height}: {what} need {need / 2**30:.1f} GiB, more than half of this "
            f"machine's memory ({budget / 2**30:.1f} GiB); {fits_w} × {fits_h} fits (a smaller width and height)")
