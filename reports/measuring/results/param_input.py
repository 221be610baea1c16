"""The parameter table's command-line side: every command's flags, ``NAME=VALUE``
assignments (``--set``, ``--vary``, sweep specs) and presets with overrides, all
derived from ``approx.params.PARAMS``."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from typing import TYPE_CHECKING, TypeVar, overload

from volcaustics.approx.params import (
    PARAMS,
    PRESET_VALUES,
    PRESETS,
    ApproxParams,
    ParamError,
    ParamsMethods,
    param,
    preset,
)

if TYPE_CHECKING:
    from volcaustics.scenes.model import Scene

_Params = TypeVar("_Params", bound=ParamsMethods)


def flag(name: str) -> str:
    """The command-line flag of a parameter: ``photon_res`` → ``--photon-res``."""
    return "--" + name.replace("_", "-")


def add_param_flags(parser: argparse.ArgumentParser, *, default_preset: str, table: tuple = PARAMS) -> None:
    """``--preset`` and one flag per parameter of ``table``, typed, with its range,
    unit and the presets' values in the help."""
    group = parser.add_argument_group("approximation parameters (default: --preset)")
    presets = "; ".join(f"{name}: the paper's values with " + ", ".join(f"{k} {v}" for k, v in changes.items())
                        for name, changes in PRESET_VALUES.items())
    group.add_argument("--preset", choices=tuple(PRESETS), default=default_preset,
                       help=f"{presets} (default {default_preset})")
    for entry in table:
        kind = {"choices": entry.choices} if entry.choices else {"type": _parser(entry), "metavar": "N"}
        group.add_argument(flag(entry.name), dest=entry.name, **kind,
                           help=f"{entry.help}: {entry.expected()}; default: the preset's")


def _parser(entry):
    """argparse ``type``: the table's typing (the range is checked with the other
    parameters, when they are made: a value out of range exits 2 naming it)."""
    def parse(text):
        try:
            return entry.parse(text)
        except ParamError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    parse.__name__ = entry.name  # argparse names the type in its message
    return parse


@overload
def params_from_args(args: argparse.Namespace) -> ApproxParams: ...


@overload
def params_from_args(args: argparse.Namespace, cls: type[_Params]) -> _Params: ...


def params_from_args(args: argparse.Namespace, cls: type[ParamsMethods] = ApproxParams) -> ParamsMethods:
    """The preset of ``args.preset`` with every parameter flag given, as ``cls`` (the
    parameters of ``approx.params.params_class``; ParamError for a value out of range)."""
    changes = {p.name: getattr(args, p.name) for p in cls.TABLE if getattr(args, p.name, None) is not None}
    return preset(args.preset, cls, **changes)


def preset_size_note(args: argparse.Namespace, params: ParamsMethods, scene: Scene) -> str | None:
    """A line saying that the preset (not ``--width``/``--height``) sets an image size other
    than ``scene``'s camera (width, height in its file): every preset has a size, which
    replaced the scene's without a word (96 × 54 rendered 256 × 256, another aspect). None
    when the size is the scene's or both flags were given."""
    size, own = (params.width, params.height), (scene.camera.width, scene.camera.height)
    if None in size or size == own or (getattr(args, "width", None) is not None
                                        and getattr(args, "height", None) is not None):
        return None
    return (f"note: the preset {args.preset} renders {size[0]} × {size[1]}, not the scene's camera "
            f"{own[0]} × {own[1]} (camera.width, camera.height); give --width {own[0]} --height {own[1]} "
            f"for the scene's size")


def parse_assignment(text: str, where: str, *, table: tuple = PARAMS) -> tuple:
    """``NAME=V1,V2`` → (name, typed values); ParamError naming ``where`` otherwise."""
    name, sep, values = text.partition("=")
    name = name.strip().replace("-", "_")
    if not sep or not name:
        raise ParamError(f"{where} {text!r}: expected NAME=VALUE[,VALUE...]")
    items = values.split(",")
    if any(not v.strip() for v in items):
        raise ParamError(f"{where} {text!r}: an empty value")
    return name, [parse_value(name, v, where, table=table) for v in items]


def parse_value(name: str, text: object, where: str, *, table: tuple = PARAMS) -> int | float | str:
    """A parameter value from text (CLI) or TOML, typed as the table declares it."""
    try:
        return param(name, table).parse(text)
    except ParamError as exc:
        raise ParamError(f"{where}: {exc}") from None


def parse_overrides(assignments: Iterable[str] | None, *, seed_option: bool = True) -> dict:
    """``--set NAME=VALUE`` (repeatable) as parameters; with ``seed_option`` (the gate,
    the report) ``seed`` is refused: it has its own option there."""
    overrides = {}
    for text in assignments or []:
        name, values = parse_assignment(text, "--set")
        if len(values) != 1:
            raise ParamError(f"--set {text!r}: one value per parameter (a sweep varies with --vary)")
        if name in overrides:
            raise ParamError(f"--set {text!r}: {name} is set twice: set it once")
        if seed_option and name == "seed":
            raise ParamError(f"--set {text!r}: use --seed (the first of the --seeds seeds)")
        overrides[name] = values[0]
    return overrides
