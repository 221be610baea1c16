"""What the commands share: the usage error, output-path checks made before any work,
scene lists, and the option groups several commands take."""

from __future__ import annotations

import argparse
import math

from volcaustics.experiment.measurement import (
    MEASUREMENT_KEYS,
    MEASUREMENT_PARAMS,
    MeasurementSettings,
    measurement_settings,
)
from volcaustics.experiment.sizing import REPORT_REFERENCE, REPORT_TARGET
from volcaustics.infra.errors import InputError
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.presenting.page.parts import debiased_pct


class UsageError(InputError):
    """A command-line value that cannot work (an output path, a list of names); the
    message names the option, the value and the fix."""

    def __init__(self, option: str, value, fix: str):
        super().__init__(f"{option} = {value!r}: {fix}")


def pct(x: float | None) -> str:
    return "   n/a" if x is None else f"{100 * x:6.2f}%"


def debiased(x: float | None, *, se: float | None = None, low: float | None = None,
             high: float | None = None) -> str:
    """A debiased relative MSE on the console, padded as :func:`pct`, with its ± SE or
    95% interval (``parts.debiased_pct``: a negative estimate reads "≤ noise")."""
    return "   n/a" if x is None else f"{debiased_pct(x, se=se, low=low, high=high):>7}"


def known(x: float) -> float | None:
    """None for a number not measured (NaN: the store's null), for the console's "n/a"."""
    return None if math.isnan(x) else x


def num(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.3f}"


def path_type(text: str) -> str:
    """An argparse type: a path, never the empty string (which would mean "not given")."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, not an empty string")
    return text


def scene_list(text: str | None, option: str) -> list[str] | None:
    """A comma-separated list of SCENE arguments; None when not given; an empty list
    or an empty name is an error (not "everything")."""
    if text is None:
        return None
    names = [s.strip() for s in text.split(",")]
    if not names or any(not n for n in names):
        raise UsageError(option, text, "expected comma-separated scene names (built-in names or .toml files)")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise UsageError(option, text, f"{repeated[0]!r} is named twice: name each scene once")
    return names


# --- option groups ---------------------------------------------------------------------

def add_budget(p: argparse.ArgumentParser, *, target: str | None, max_seconds: float) -> None:
    """--target-noise and its caps (the reference's render budget)."""
    p.add_argument("--target-noise", dest="target_noise", default=target, metavar="F",
                   help="render batches until every colour component's noise floor (sum var / sum mean^2 over "
                        "non-glass pixels) is at most F: a number (all components) or caustic=F,fog=F,direct=F; "
                        f"'none' renders exactly --batches (default: {target or 'none'})")
    p.add_argument("--max-photons", dest="max_photons", type=int, default=1 << 34,
                   help="photon cap of a --target-noise render (default 2^34)")
    p.add_argument("--max-seconds", dest="max_seconds", type=float, default=max_seconds,
                   help=f"time cap of a --target-noise render, seconds (default {max_seconds:g})")


def budget(args: argparse.Namespace) -> dict:
    """target_noise and its caps from the command line ("none" turns the target off)."""
    target = args.target_noise
    if target is not None and target.strip().lower() == "none":
        target = None
    return {"target_noise": target, "max_photons": args.max_photons, "max_seconds": args.max_seconds}


def add_report_reference(p: argparse.ArgumentParser, defaults: ReferenceSettings = REPORT_REFERENCE,
                         target: str | None = REPORT_TARGET, per: str = "") -> None:
    """The reference options of ``report`` and ``measure`` (default: the report's budget);
    ``animate`` passes its own ``defaults`` and ``target`` (``per``: " per frame")."""
    photons = f"2^{defaults.photons.bit_length() - 1}" if defaults.photons & (defaults.photons - 1) == 0 \
        else str(defaults.photons)
    p.add_argument("--photons", type=int, default=defaults.photons,
                   help=f"reference photons{per} over --batches batches: with the target, the size of a batch "
                        f"(default {photons})")
    p.add_argument("--spp", type=int, default=defaults.spp,
                   help=f"reference camera samples per pixel{per} over --batches batches (default {defaults.spp})")
    p.add_argument("--batches", type=int, default=defaults.batches,
                   help=f"reference batches per stream{per}, at least (default {defaults.batches})")
    p.add_argument("--max-scatter", dest="max_scatter", type=int, default=defaults.max_scatter, metavar="K",
                   help=f"scattering orders of the reference{per}: with K > 1 it also renders what orders 2..K add, "
                        f"the single-scattering model's own error (default {defaults.max_scatter})")
    add_budget(p, target=target, max_seconds=defaults.max_seconds)


def report_settings(args: argparse.Namespace) -> ReferenceSettings:
    """The reference settings of ``report``, ``measure`` and ``animate`` (unsized: the
    runner, or ``animate``, sizes them)."""
    return ReferenceSettings(photons=args.photons, spp=args.spp, batches=args.batches, max_scatter=args.max_scatter,
                             **budget(args))


def add_measurement_flags(p: argparse.ArgumentParser, *, default: str = "{value}, the report's") -> None:
    """One flag per measurement setting (``experiment.measurement``), e.g.
    ``--exact-subphotons N``; ``default`` says where an unset one comes from (``{value}``:
    the report's value)."""
    for param in MEASUREMENT_PARAMS:
        if param.name in MEASUREMENT_KEYS:
            p.add_argument("--" + param.name.replace("_", "-"), dest=param.name, type=int, metavar="N",
                           help=f"{param.help}, {param.low} to {param.high} (a measurement setting, part of a "
                                f"result's key; default: {default.format(value=param.default)})")


def measurement_from_args(args: argparse.Namespace, base: MeasurementSettings | None = None) -> MeasurementSettings:
    """``base`` (default: the report's measurement settings) with every measurement flag
    given; ParamError naming the flag, its value and the range otherwise."""
    settings = base or MeasurementSettings()
    for name in MEASUREMENT_KEYS:
        settings = measurement_settings({name: getattr(args, name, None)}, base=settings,
                                        where="--" + name.replace("_", "-"))
    return settings


def add_gate_inputs(p: argparse.ArgumentParser, *, scenes: str) -> None:
    """What the gate and the report measure and check: scenes, parameters over the
    budgets' preset, seeds, budgets and the baseline."""
    p.add_argument("--scenes", help=scenes)
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="an approximation parameter over the budgets' preset (repeatable)")
    p.add_argument("--seeds", type=int, help="frames per scene (default: the budgets' seeds; the built-in ones say 6)")
    p.add_argument("--seed", type=int, default=0, help="the first seed (default 0)")
    p.add_argument("--budgets", type=path_type, metavar="FILE.toml",
                   help="budgets per scene (default: reports/studies/gate/budgets.toml)")
    p.add_argument("--baseline", type=path_type, metavar="DIR",
                   help="the last accepted results (DIR/baseline.json): also test for a regression against them")
