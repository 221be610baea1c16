"""The splat modes are a registry (approx.splat_modes.SPLAT_MODES): the parameter table's
choices and help, the decomposition's kernel rules and the shaders' defines all follow it."""

from __future__ import annotations

import dataclasses

import pytest

from volcaustics.approx.params import PARAMS, QUICK, ParamError, defines, preset
from volcaustics.approx.splat_modes import SPLAT_MODES, splat_mode
from volcaustics.experiment.kernels import KERNEL_RULES


def test_the_table_offers_every_registered_mode_and_says_what_each_is():
    (splat,) = [p for p in PARAMS if p.name == "splat"]
    assert splat.choices == tuple(SPLAT_MODES) and splat.default == "fixed"
    assert all(mode.help.split(" (")[0] == name and mode.help in splat.help for name, mode in SPLAT_MODES.items())
    with pytest.raises(ParamError, match="splat"):  # a name not registered is refused by the table
        preset("quick", splat="photons")


def test_every_mode_has_a_kernel_rule_and_at_most_one_kind():
    """The decomposition can say what kernels it replays for every mode, and a mode is at
    most one of beams, differential widths or a density pass (fixed: none)."""
    assert set(SPLAT_MODES) <= set(KERNEL_RULES)
    for mode in SPLAT_MODES.values():
        assert sum((mode.beams, mode.differential_width, mode.density_pass)) == (mode.name != "fixed"), mode


@pytest.mark.parametrize("name", list(SPLAT_MODES))
def test_a_params_mode_is_its_registry_entry(name):
    p = dataclasses.replace(QUICK, splat=name)
    assert splat_mode(p) is SPLAT_MODES[name]
    assert ("SPLAT_" + name.upper() in defines(p, "trace")) == (name != "fixed")  # the shaders' switch
