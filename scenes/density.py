"""A heterogeneous medium's density: σs(x) = ρ(x)·σs and σa(x) = ρ(x)·σa, ρ ≥ 0.

:class:`Density` says where ρ comes from: a procedural field (``scenes.density_fields``)
baked onto a grid of ``resolution`` cells over a box (the scene's medium box unless the
scene names one), or a grid file (``scenes.volume_files``: ``.npy`` over a stated box, or
Mitsuba's ``.vol``, which states its own). :func:`baked_grid` gives the
:class:`DensityGrid` both renderers read (``scenes.medium_grid.density_grid`` of a scene).

The grid's one convention, the one a GL 3D texture with linear filtering and
clamp-to-edge and Dr.Jit's ``Texture3f`` use: ``values[k, j, i]`` is ρ at the centre of cell
(i, j, k), ((i + ½)/nx, (j + ½)/ny, (k + ½)/nz) of the box; between centres ρ is trilinear,
beyond the outermost centres it is clamped, and outside the box it is 0 (the medium box
lies inside it: the loader refuses a grid that does not cover the medium).

Majorants: the coarse grid of :meth:`DensityGrid.majorants` bounds ρ in blocks of cells
(with the samples that reach into a block by interpolation), so a tracker steps a thin wisp
at its own density, not at the whole box's maximum (Novák et al. 2014, "Residual ratio
tracking"; a grid of majorants as in Mitsuba 3's ``heterogeneous`` medium).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from .density_fields import FIELD_VERSION, FIELDS, field_values
from .volume_files import read_grid

Box = tuple[tuple[float, float, float], tuple[float, float, float]]
DEFAULT_RESOLUTION = (32, 32, 32)  # cells (x, y, z) a field is baked onto, unless the scene says
MAJORANT_BLOCK = 4                 # cells per majorant cell along each axis


@dataclass(frozen=True)
class Density:
    """Where a medium's density comes from: a ``field`` (a name in
    ``scenes.density_fields.FIELDS``) with ``params`` (sorted key/value pairs) baked at
    ``resolution`` (cells along x, y, z), or a grid file ``path`` (absolute) whose bytes
    hash to ``content_hash``. ``box`` ((min, max) corners, m) is where the grid lies; None:
    the scene's medium box (a field) or the box a ``.vol`` states."""

    field: str | None = None
    params: tuple[tuple[str, Any], ...] = ()
    resolution: tuple[int, int, int] = DEFAULT_RESOLUTION
    path: str | None = None
    content_hash: str | None = None
    box: Box | None = None

    def __post_init__(self):
        if self.field is not None:  # every parameter stated, sorted: one field, one text, one hash
            spec = FIELDS[self.field].params
            unknown = sorted(set(dict(self.params)) - set(spec))
            if unknown:
                raise ValueError(f"density field {self.field!r}: unknown parameter {unknown[0]!r}; "
                                 f"it has {', '.join(spec)}")
            params = {name: p.default for name, p in spec.items()} | dict(self.params)
            object.__setattr__(self, "params", tuple(sorted(params.items())))

    @property
    def label(self) -> str:
        return self.path if self.path is not None else f"field {self.field}"

    def canonical(self) -> dict:
        """What enters the scene hash: the field and its parameters, or the file's content."""
        box = None if self.box is None else [[float(x) for x in corner] for corner in self.box]
        if self.path is not None:
            return {"file_sha256": self.content_hash, "box": box}
        params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.params}
        return {"field": self.field, "field_version": FIELD_VERSION, "params": params,
                "resolution": list(self.resolution), "box": box}


@dataclass(frozen=True, eq=False)
class DensityGrid:
    """ρ on a grid: ``values`` [nz, ny, nx] float32 (≥ 0, finite) over the box ``lo``..``hi``
    ((3,) float64, m); the module docstring gives the convention."""

    values: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @property
    def resolution(self) -> tuple[int, int, int]:
        """Cells along (x, y, z)."""
        nz, ny, nx = self.values.shape
        return nx, ny, nz

    def eval(self, points: np.ndarray) -> np.ndarray:
        """ρ at ``points`` (N×3, m): N float64; trilinear between cell centres, 0 outside the box."""
        p = np.asarray(points, np.float64).reshape(-1, 3)
        res = np.asarray(self.resolution)
        u = (p - self.lo) / (self.hi - self.lo) * res - 0.5
        inside = np.all((p >= self.lo) & (p <= self.hi), axis=1)
        base = np.floor(u)
        f = u - base
        base = base.astype(np.int64)
        a, b = np.clip(base, 0, res - 1), np.clip(base + 1, 0, res - 1)
        flat = self._flat()
        nx, ny = int(res[0]), int(res[1])
        out = 0.0
        for z, wz in ((a[:, 2], 1.0 - f[:, 2]), (b[:, 2], f[:, 2])):
            for y, wy in ((a[:, 1], 1.0 - f[:, 1]), (b[:, 1], f[:, 1])):
                row = (z * ny + y) * nx
                out = out + wz * wy * ((1.0 - f[:, 0]) * flat[row + a[:, 0]] + f[:, 0] * flat[row + b[:, 0]])
        return np.where(inside, out, 0.0)

    def _flat(self) -> np.ndarray:
        """The values as one float64 row (x fastest), made once."""
        flat = self.__dict__.get("_flat_values")
        if flat is None:
            flat = self.values.astype(np.float64).ravel()
            object.__setattr__(self, "_flat_values", flat)
        return flat

    def majorants(self, block: int = MAJORANT_BLOCK) -> np.ndarray:
        """The coarse majorant grid [mz, my, mx] float32, m = ⌈n / block⌉: each value bounds ρ
        everywhere in its block of ``block``³ cells (the cells' samples and the neighbours'
        that trilinear interpolation reaches into it). Made once per block size."""
        made = self.__dict__.setdefault("_majorant_grids", {})
        if block not in made:
            made[block] = self._majorants(block)
            made[block].setflags(write=False)
        return made[block]

    def _majorants(self, block: int) -> np.ndarray:
        padded = np.pad(self.values, 1, mode="edge")
        counts = [-(-n // block) for n in self.values.shape]
        out = np.empty(counts, np.float32)
        for k in range(counts[0]):
            for j in range(counts[1]):
                for i in range(counts[2]):
                    # cells [c·block, (c+1)·block) read samples c·block − 1 … (c+1)·block: padded +1
                    out[k, j, i] = padded[k * block:(k + 1) * block + 2, j * block:(j + 1) * block + 2,
                                          i * block:(i + 1) * block + 2].max()
        return out


def grid_problem(values: np.ndarray) -> str | None:
    """Why ``values`` is no density grid (None if it is one): NaN or infinite, or negative."""
    finite = np.isfinite(values)
    if not finite.all():
        k, j, i = (int(x) for x in np.argwhere(~finite)[0])
        return f"finite densities; cell [z={k}, y={j}, x={i}] holds {values[k, j, i]} ({int((~finite).sum())} such)"
    if (values < 0).any():
        k, j, i = (int(x) for x in np.argwhere(values < 0)[0])
        return f"densities >= 0; cell [z={k}, y={j}, x={i}] holds {values[k, j, i]:g} ({int((values < 0).sum())} such)"
    return None


def covers(box: Box, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether ``box`` contains the box ``lo``..``hi``."""
    return bool(np.all(np.asarray(box[0]) <= lo) and np.all(np.asarray(box[1]) >= hi))


@lru_cache(maxsize=8)
def baked_grid(density: Density, lo: tuple, hi: tuple) -> DensityGrid:
    """The grid of ``density`` (read from its file, or its field baked at its resolution) over
    its box, or over the box ``lo``..``hi`` (the medium's) when it states none; made once."""
    if density.path is not None:
        values, stated = read_grid(density.path)
        box = density.box or stated
        assert box is not None, "the loader gives a .npy grid its box"
    else:
        box = density.box or (lo, hi)
        nx, ny, nz = density.resolution
        low, high = np.asarray(box[0], np.float64), np.asarray(box[1], np.float64)
        axes = [low[a] + (np.arange(n) + 0.5) / n * (high[a] - low[a]) for a, n in enumerate((nx, ny, nz))]
        z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
        points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
        values = field_values(str(density.field), dict(density.params), points).reshape(nz, ny, nx).astype(np.float32)
    values.setflags(write=False)
    return DensityGrid(values, np.asarray(box[0], np.float64), np.asarray(box[1], np.float64))
