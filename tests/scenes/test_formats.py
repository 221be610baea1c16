"""The shared formats: codes, component names, record layouts, sigma_bar and the box exit."""

from __future__ import annotations

import numpy as np
import pytest

from volcaustics.scenes import formats
from volcaustics.scenes.bounds import box_exit
from volcaustics.scenes.formats import (
    FLAG_BITS,
    KIND_NONE,
    LAYER_NAMES,
    MASK_LAYER,
    RAW_RECORD_DTYPE,
    RECORD_DTYPE,
    SHAPE_KINDS,
    STATUS_CODES,
    STATUS_NAMES,
)
from volcaustics.scenes.model import Medium


def test_code_tables_name_every_constant_once():
    for table, prefix in ((STATUS_CODES, "STATUS_"), (FLAG_BITS, "FLAG_"), (SHAPE_KINDS, "KIND_")):
        constants = {n: v for n, v in vars(formats).items() if n.startswith(prefix) and isinstance(v, int)}
        assert table == constants, prefix
        assert len(set(table.values())) == len(table), f"{prefix} codes collide"
    assert set(STATUS_NAMES) == set(STATUS_CODES.values())
    assert all(bit & (bit - 1) == 0 and bit > 0 for bit in FLAG_BITS.values())  # one bit each
    assert KIND_NONE == 0  # a G-buffer cleared to zero reads as "no surface"


def test_codes_fit_their_record_fields():
    status_max, flags_max = np.iinfo(RECORD_DTYPE["status"]).max, np.iinfo(RECORD_DTYPE["flags"]).max
    assert max(STATUS_CODES.values()) <= status_max
    assert sum(FLAG_BITS.values()) <= flags_max
    assert RAW_RECORD_DTYPE.itemsize == 7 * 16


def test_component_names_are_design_md_layers():
    assert LAYER_NAMES == ("caustic", "fog", "direct", "combined", "mask_specular")
    assert LAYER_NAMES[-1] == MASK_LAYER


def test_sigma_bar_is_the_mean_extinction():
    m = Medium(sigma_s=(0.1, 0.2, 0.3), sigma_a=(0.3, 0.0, 0.3))
    assert m.sigma_bar == pytest.approx(0.4)
    assert Medium().sigma_bar == 0.0
    assert isinstance(m.sigma_bar, float)


def test_box_exit_on_a_unit_box():
    lo, hi = np.zeros(3), np.ones(3)
    origins = np.array([[0.5, 0.5, 0.5], [0.5, 0.5, 0.5], [0.25, 0.5, 0.5], [0.5, 0.5, 0.5], [1.0, 0.5, 0.5]])
    s = 1 / np.sqrt(3)
    directions = np.array([[1, 0, 0], [0, -1, 0], [-1, 0, 0], [s, s, s], [1, 0, 0]], np.float64)
    assert np.allclose(box_exit(origins, directions, lo, hi), [0.5, 0.5, 0.25, 0.5 / s, 0.0])
