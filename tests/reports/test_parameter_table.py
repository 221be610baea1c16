"""The parameter table (approx/params.py) drives every command: each parameter is a flag
of `approx` and `measure`, a `sweep --vary` axis, and a value out of range is refused
with the range the table declares. A parameter added to a copy of the table reaches the
flags, the sweep's grid and the tracer's program key with no other edit."""

from __future__ import annotations

import argparse
import dataclasses

import pytest

from volcaustics.approx.params import PARAMS, ApproxParams, Param, ParamError, params_class, preset
from volcaustics.approx.trace import PhotonTracer
from volcaustics.reports.cli import build_parser, main
from volcaustics.reports.measuring.results.param_input import add_param_flags, flag, params_from_args, parse_assignment
from volcaustics.reports.studies.sweep.sweep_spec import ANIMATE_ONLY, SweepSpec, points


def _bad_value(entry: Param):
    """A value of the right type just outside the table's range (or not a choice)."""
    if entry.choices:
        return "nosuch"
    return entry.high + 1 if entry.kind is int else entry.high * 2


def _good_value(entry: Param):
    """An allowed value other than the default."""
    if entry.choices:
        return entry.choices[-1]
    if entry.kind is int:
        return entry.low if entry.low != entry.default else entry.high  # fresnel_splits: its default is its low
    return entry.high / 4


def _help(command: str) -> str:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[command].format_help()


@pytest.mark.parametrize("command", ["approx", "measure"])
def test_every_parameter_is_a_flag_with_its_range(command):
    text = " ".join(_help(command).split())  # argparse wraps lines
    for entry in PARAMS:
        assert flag(entry.name) in text, entry.name
        assert entry.expected() in text, (entry.name, entry.expected())


@pytest.mark.parametrize("entry", PARAMS, ids=[p.name for p in PARAMS])
def test_every_parameter_is_a_sweep_axis_and_a_bad_value_names_the_range(entry, tmp_path, capsys, empty_cache):
    name, values = parse_assignment(f"{entry.name}={_good_value(entry)}", "--vary")
    assert name == entry.name and values == [_good_value(entry)]
    # seed is not a grid axis (a point has seeds seed … seed + seeds − 1), nor are the animate-only
    # parameters (every value the same point): they are set, and checked the same way
    option = "--set" if entry.name in ("seed", *ANIMATE_ONLY) else "--vary"
    argv = ["sweep", "-o", str(tmp_path / "s"), "--scenes", "sphere1", option, f"{entry.name}={_bad_value(entry)}",
            "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert entry.name in err and entry.expected() in err, err
    assert not (tmp_path / "cache" / "reference").exists()  # refused before any reference renders


def test_a_flag_out_of_range_exits_2_naming_the_range(tmp_path, capsys):
    entry = next(p for p in PARAMS if p.name == "layers")
    assert main(["approx", "sphere1", "-o", str(tmp_path / "a.exr"), "--layers", str(_bad_value(entry))]) == 2
    assert entry.expected() in capsys.readouterr().err


def test_presets_mean_one_thing_everywhere():
    assert preset("paper") == ApproxParams(width=800, height=800)
    args = build_parser().parse_args(["approx", "sphere1", "-o", "x.exr", "--preset", "paper"])
    assert params_from_args(args) == preset("paper")
    spec = SweepSpec(scenes=("sphere1",), vary=(), preset="paper")
    assert [p.params for p in points(spec)] == [preset("paper")]


# a parameter no code uses yet: a define of the trace program, as a new search variant would be
DUMMY = Param("search_budget", int, 3, "a parameter added by a test", "", 0, 9, program="trace", glsl="define")


@pytest.fixture
def table():
    """A copy of the table with one more parameter, and its parameter class."""
    extended = (*PARAMS, DUMMY)
    return extended, params_class(extended)


def test_an_added_parameter_reaches_the_flags(table):
    extended, cls = table
    parser = argparse.ArgumentParser()
    add_param_flags(parser, default_preset="quick", table=extended)
    assert "--search-budget" in parser.format_help() and "an integer in [0, 9]" in parser.format_help()
    params = params_from_args(parser.parse_args(["--search-budget", "5"]), cls)
    assert params.search_budget == 5 and params.photon_res == preset("quick").photon_res
    with pytest.raises(ParamError, match=r"search_budget = 10: expected an integer in \[0, 9\]"):
        params_from_args(parser.parse_args(["--search-budget", "10"]), cls)


def test_an_added_parameter_reaches_the_sweep(table):
    extended, cls = table
    name, values = parse_assignment("search_budget=1,7", "--vary", table=extended)
    spec = SweepSpec(scenes=("sphere1",), vary=((name, tuple(values)),), preset="quick")
    grid = points(spec, cls)
    assert [p.params.search_budget for p in grid] == [1, 7]
    assert all(dataclasses.replace(p.params, search_budget=3) == preset("quick", cls) for p in grid)
    with pytest.raises(ParamError, match="search_budget"):
        parse_assignment("search_budget=x", "--vary", table=extended)


def test_an_added_parameter_reaches_the_program_key(table):
    _, cls = table
    one, other = PhotonTracer.defines(cls(search_budget=1)), PhotonTracer.defines(cls(search_budget=2))
    assert one["SEARCH_BUDGET"] == 1 and other["SEARCH_BUDGET"] == 2
    assert {k: v for k, v in one.items() if k != "SEARCH_BUDGET"} == PhotonTracer.defines(ApproxParams())


# define parameters that select a program only beside another parameter's value: beam_width
# changes nothing but beams (one program for the other splat modes)
_CONTEXT = {"beam_width": {"splat": "beams"}}


def test_the_program_key_follows_the_define_parameters_only():
    for entry in PARAMS:
        context = ApproxParams(**_CONTEXT.get(entry.name, {}))
        base = PhotonTracer.defines(context)
        changed = PhotonTracer.defines(dataclasses.replace(context, **{entry.name: _good_value(entry)}))
        assert (changed != base) == (entry.glsl == "define" and entry.program == "trace"), entry.name
    # and where it changes nothing, it is not in the key
    assert PhotonTracer.defines(ApproxParams(beam_width="differential")) == PhotonTracer.defines(ApproxParams())


def test_the_docs_list_every_parameter_with_its_default():
    """The parameter table of docs/approx.md (a copy for readers) follows the table: a parameter
    added, renamed or given another default fails here until the page says so."""
    import os
    import re

    readme = open(os.path.join(os.path.dirname(__file__), "..", "..", "docs", "approx.md"), encoding="utf-8").read()
    rows = {}
    for names, default in re.findall(r"^\| (`[a-z_]+`(?:, `[a-z_]+`)*) \| ([^|]+) \|", readme, flags=re.M):
        for name in re.findall(r"`([a-z_]+)`", names):
            rows[name] = default.strip()
    for entry in PARAMS:
        assert entry.name in rows, entry.name
        if entry.default is not None:
            assert rows[entry.name].split()[0] == f"{entry.default:g}" if entry.kind is float else \
                rows[entry.name].split()[0] == str(entry.default), (entry.name, rows[entry.name])
