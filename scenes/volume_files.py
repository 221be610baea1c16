"""Density grid files: NumPy ``.npy`` and Mitsuba 3's binary ``.vol``.

A grid is an array ``[nz, ny, nx]`` of float32 densities, x varying fastest in memory, the
layout of a GL 3D texture and of Mitsuba's ``VolumeGrid`` (``[z, y, x, channels]``).

Mitsuba's ``.vol`` (its ``gridvolume`` plugin documents it): the bytes ``VOL``, the version
3 (one byte), then little-endian int32 encoding (1: float32), xres, yres, zres and
channels, six float32 for the bounding box (xmin, ymin, zmin, xmax, ymax, zmax), then the
float32 values, channels innermost, then x, y, z. The box is the file's own: a ``.vol``
says where it lies, a ``.npy`` does not (the scene file gives its ``box``).

OpenVDB: no maintained package serves it to this project's Python (PyPI has none; Debian's
``python3-openvdb`` is built for the system Python alone); convert a ``.vdb`` to ``.npy``
with OpenVDB's own tools (docs/scene-format.md).
"""

from __future__ import annotations

import os

import numpy as np

VOL_MAGIC = b"VOL\x03"
VOL_HEADER = np.dtype([("magic", "S4"), ("encoding", "<i4"), ("res", "<i4", 3), ("channels", "<i4"),
                       ("box", "<f4", 6)])
GRID_SUFFIXES = (".npy", ".vol")


class GridFileError(ValueError):
    """A grid file that cannot be read as a density grid (the message says why)."""


def read_grid(path: str) -> tuple[np.ndarray, tuple[tuple[float, ...], tuple[float, ...]] | None]:
    """The density grid in ``path`` (``[nz, ny, nx]`` float32, any values: the caller
    checks them) and the box the file states ((min, max) corners, metres) or None.

    Raises
    ------
    GridFileError
        Not a ``.npy`` or ``.vol`` file, unreadable, truncated, not three-dimensional,
        more than one channel, or not numbers.
    """
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in GRID_SUFFIXES:
        raise GridFileError(f"a density grid file ends in {' or '.join(GRID_SUFFIXES)} (OpenVDB: convert to .npy)")
    try:
        if suffix == ".npy":
            return _npy(path), None
        return _vol(path)
    except OSError as exc:
        raise GridFileError(f"cannot read it ({exc.strerror or exc})") from None


def _npy(path: str) -> np.ndarray:
    try:
        values = np.load(path, allow_pickle=False)
    except ValueError as exc:  # not a .npy, pickled objects, truncated
        raise GridFileError(f"not a readable .npy array ({exc})") from None
    if values.ndim != 3:
        raise GridFileError(f"an array of shape [nz, ny, nx]; this one has shape {list(values.shape)}")
    if not np.issubdtype(values.dtype, np.number) or np.issubdtype(values.dtype, np.complexfloating):
        raise GridFileError(f"an array of real numbers; this one holds {values.dtype}")
    return np.ascontiguousarray(values, dtype=np.float32)


def _vol(path: str) -> tuple[np.ndarray, tuple[tuple[float, ...], tuple[float, ...]]]:
    with open(path, "rb") as fh:
        raw = fh.read()
    if len(raw) < VOL_HEADER.itemsize or raw[:4] != VOL_MAGIC:
        raise GridFileError("not a Mitsuba .vol file (it starts with the bytes VOL and version 3)")
    header = np.frombuffer(raw[:VOL_HEADER.itemsize], VOL_HEADER)[0]
    nx, ny, nz = (int(n) for n in header["res"])
    channels = int(header["channels"])
    if int(header["encoding"]) != 1:
        raise GridFileError(f"a float32 .vol (encoding 1); this one has encoding {int(header['encoding'])}")
    if channels != 1:
        raise GridFileError(f"a one-channel density grid; this .vol has {channels} channels")
    if min(nx, ny, nz) < 1:
        raise GridFileError(f"a resolution of at least 1 on every axis; this .vol says {[nx, ny, nz]}")
    count = nx * ny * nz
    body = raw[VOL_HEADER.itemsize:]
    if len(body) != 4 * count:
        raise GridFileError(f"{count} float32 values for its resolution {[nx, ny, nz]}; it holds {len(body)} bytes")
    box = [float(v) for v in header["box"]]
    return np.frombuffer(body, "<f4").reshape(nz, ny, nx).astype(np.float32), (tuple(box[:3]), tuple(box[3:]))


def vol_bytes(values: np.ndarray, lo: np.ndarray | tuple, hi: np.ndarray | tuple) -> bytes:
    """A Mitsuba ``.vol`` file's bytes: ``values`` ``[nz, ny, nx]`` or ``[nz, ny, nx, channels]``
    float32 over the box (``lo``, ``hi``)."""
    grid = np.asarray(values, np.float32)
    if grid.ndim == 3:
        grid = grid[..., None]
    nz, ny, nx, channels = grid.shape
    header = np.zeros((), VOL_HEADER)
    header["magic"], header["encoding"], header["channels"] = VOL_MAGIC, 1, channels
    header["res"] = (nx, ny, nz)
    header["box"] = (*(float(v) for v in lo), *(float(v) for v in hi))
    return header.tobytes() + np.ascontiguousarray(grid, "<f4").tobytes()
