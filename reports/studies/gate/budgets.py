"""The gate's budgets: per scene, limits on the debiased relative MSE, the energy ratio,
HDR-FLIP and the step-2 segment classes, and their checks on one result.

Budgets (TOML; ``reports/studies/gate/budgets.toml`` is the default for the built-ins)::

    preset = "quick"            # the approximation's parameters (``--set`` overrides)
    seeds = 4                   # frames per scene: seeds 0 … seeds − 1
    [scene.bunny]
    caustic.relmse_max = 0.30         # debiased relative MSE (metrics.noise.seed_relative_mse)
    caustic.frame_relmse_max = 0.40   # one frame's relative MSE less the floor (metrics.frame)
    caustic.energy_ratio = [0.3, 0.5] # Σ approx / Σ reference, averaged over RGB
    caustic.hdr_flip_max = 0.95       # mean HDR-FLIP over frames
    combined.relmse_max = 0.02
    segments.missed_step2_max = 0.05  # step-2 segments missed (inside glass or in the medium)
    segments.dt_p90_step2_max = 0.006 # |Δt| p90 of step-2 true hits, m
    [animation.refocus]               # checked on `gate --animation DIR` (volcaustics animate)
    caustic.flicker_max = 0.05        # mean flicker over the frame pairs, fixed seed (metrics.temporal)
    caustic.flicker_per_frame_max = 0.08  # the same with a new seed every frame
    [compare.myengine.bunny]          # checked on `gate --compare myengine=DIR` (volcaustics compare)
    caustic.relmse_max = 0.40         # the component limits above, on another renderer's images
    combined.energy_ratio = [0.9, 1.1]

A budget tighter than the measurement can resolve — a relative-MSE limit below the
reference's floor plus 3 standard errors, an energy band narrower than 3 σ of the
reference's total — is refused (exit 2), naming it. The regression test is
``gate.regression``; the verdict on one result, ``gate.verdict``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from volcaustics.approx.params import PRESETS
from volcaustics.experiment.measurement import measurement_settings
from volcaustics.experiment.sizing import REFERENCE_KEYS, reference_settings
from volcaustics.infra.errors import InputError
from volcaustics.reports.measuring.results.tomlfile import load_toml
from volcaustics.scenes import SceneError, resolve_scene
from volcaustics.scenes.catalogue import scene_relative_to

if TYPE_CHECKING:
    from typing import Protocol

    from volcaustics.approx.params import ApproxParams
    from volcaustics.experiment.result import Estimate, Experiment
    from volcaustics.reports.studies.animate.animation_read import MeasuredAnimation
    from volcaustics.reports.studies.compare.comparison_read import ComparedRenderer

    class MeasuredResult(Protocol):
        """What the gate reads of a measured result (``reports.measuring.runner.PointResult``):
        its typed experiment and its segment records."""

        @property
        def experiment(self) -> Experiment: ...

        @property
        def segments(self) -> list: ...

RESOLVE_SIGMAS = 3.0    # a budget must lie this many standard errors beyond the noise
COMPONENT_KEYS = ("relmse_max", "frame_relmse_max", "energy_ratio", "hdr_flip_max")
RELMSE_KEYS = {"relmse_max": "relative_mse", "frame_relmse_max": "frame_relative_mse"}  # budget → its metric
SEGMENT_KEYS = ("missed_step2_max", "dt_p90_step2_max")
FLICKER_KEYS = {"flicker_max": "fixed", "flicker_per_frame_max": "per-frame"}  # budget → the seed mode it checks
COMPONENTS = ("caustic", "fog", "direct", "combined")
TOP_KEYS = ("preset", "seeds", "scene", "reference", "measurement", "animation", "compare")


class GateError(InputError):
    """Bad budgets, a missing reference or baseline, a NaN metric: exit 2."""


@dataclass
class Check:
    scene: str
    name: str        # e.g. "caustic.relmse_max", "regression.caustic_relmse"
    value: float
    limit: str       # the limit as text ("≤ 0.30", "[0.3, 0.5]", "p < 0.01")
    passed: bool
    message: str = ""
    images: dict = field(default_factory=dict)   # label → path of the images written for a failure
    detail: dict = field(default_factory=dict)   # e.g. p-value, detectable increase


def default_budgets_path() -> str:
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "budgets.toml")


def media_budgets_path() -> str:
    """The media scenes' budgets (``make report-media``): scenes/media, gated apart."""
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "media_budgets.toml")


def load_budgets(path: str) -> dict:
    """{"preset", "seeds", "scenes": {name: {check: limit}}, "scene_args": {name: SCENE
    argument}, "path", "reference_settings", "measurement"}, validated. A scene file named by a relative
    path is relative to the budgets file (``scenes.catalogue.scene_relative_to``)."""
    doc = load_toml(path, keys=TOP_KEYS, what="budgets")
    seeds = doc.get("seeds", 4)
    if isinstance(seeds, bool) or not isinstance(seeds, int) or not 2 <= seeds <= 256:
        raise GateError(f"{path}: seeds = {seeds!r}: expected an integer in [2, 256] (the regression test needs 2)")
    preset = doc.get("preset", "quick")
    if preset not in PRESETS:
        raise GateError(f"{path}: preset = {preset!r}: expected {' or '.join(repr(n) for n in PRESETS)}")
    scenes = doc.get("scene")
    if not isinstance(scenes, dict) or not scenes:
        raise GateError(f"{path}: no [scene.NAME] table: nothing to gate")
    out, args = {}, {}
    for name, table in scenes.items():
        if not isinstance(table, dict) or not table:
            raise GateError(f"{path}: scene.{name} = {table!r}: expected a table of budgets")
        args[name] = scene_relative_to(name, path)  # a scene file: relative to this file, as in a sweep spec
        try:  # a scene that does not exist is a typo found now, not after the others were measured
            resolve_scene(args[name])
        except SceneError as exc:
            raise GateError(f"{path}: scene.{name}: {exc}") from None
        out[name] = _limits(path, f"scene.{name}", table, ("segments", *COMPONENTS))
    animations = _flicker_budgets(path, doc.get("animation", {}))
    compared = _compare_budgets(path, doc.get("compare", {}))
    reference = doc.get("reference", {})
    if not isinstance(reference, dict) or any(k not in REFERENCE_KEYS for k in reference):
        raise GateError(f"{path}: reference = {reference!r}: expected a table of {', '.join(REFERENCE_KEYS)}")
    try:
        settings = reference_settings(reference)
    except InputError as exc:
        raise GateError(f"{path}: {exc}") from None
    measurement = doc.get("measurement", {})
    if not isinstance(measurement, dict):
        raise GateError(f"{path}: measurement = {measurement!r}: expected a table [measurement]")
    return {"preset": preset, "seeds": seeds, "scenes": out, "scene_args": args, "path": path,
            "reference_settings": settings, "animations": animations, "compare": compared,
            "measurement": measurement_settings(measurement, where=f"{path}: measurement")}


def _limits(path: str, where: str, table: dict, groups: tuple) -> dict:
    """A scene's limits ``{group: {key: limit}}`` → {"group.key": limit}, validated:
    ``groups`` are the component names (COMPONENT_KEYS) and "segments" (SEGMENT_KEYS)."""
    checks = {}
    for group, values in table.items():
        if not isinstance(values, dict):
            raise GateError(f"{path}: {where}.{group}: expected a table of limits")
        if group not in groups:
            raise GateError(f"{path}: {where}.{group}: expected {', '.join(groups)}")
        allowed = SEGMENT_KEYS if group == "segments" else COMPONENT_KEYS
        for key, limit in values.items():
            at = f"{path}: {where}.{group}.{key}"
            if key not in allowed:
                raise GateError(f"{at}: unknown; expected {', '.join(allowed)}")
            if key == "energy_ratio":
                if (not isinstance(limit, list) or len(limit) != 2
                        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in limit)
                        or not 0 <= limit[0] < limit[1]):
                    raise GateError(f"{at} = {limit!r}: expected [low, high] with 0 ≤ low < high")
            elif isinstance(limit, bool) or not isinstance(limit, (int, float)) or not limit > 0 \
                    or not math.isfinite(limit):
                raise GateError(f"{at} = {limit!r}: expected a positive number")
            checks[f"{group}.{key}"] = limit
    return checks


def _compare_budgets(path: str, tables) -> dict:
    """``[compare.RENDERER.SCENE]``: renderer → scene name → {"component.key": limit}
    (the component limits; another renderer has no segment records)."""
    if not isinstance(tables, dict):
        raise GateError(f"{path}: compare = {tables!r}: expected [compare.RENDERER.SCENE] tables")
    out: dict = {}
    for renderer, scenes in tables.items():
        if not isinstance(scenes, dict) or not scenes or not all(isinstance(t, dict) for t in scenes.values()):
            raise GateError(f"{path}: compare.{renderer}: expected [compare.{renderer}.SCENE] tables of limits")
        out[renderer] = {}
        for scene, table in scenes.items():
            if not table:
                raise GateError(f"{path}: compare.{renderer}.{scene}: expected a table of limits")
            out[renderer][scene] = _limits(path, f"compare.{renderer}.{scene}", table, COMPONENTS)
    return out


def compare_checks(comparison: ComparedRenderer, renderer: str, limits: dict, path: str) -> list:
    """Another renderer's comparison (``compare``'s output, read back) against its budgets,
    as :func:`budget_checks` holds the approximation to them; checks named
    ``compare.RENDERER.component.key``."""
    c = comparison
    for name in limits:
        group = name.split(".", 1)[0]
        if group not in c.components:
            raise GateError(f"{path}: compare.{renderer}.{c.scene}.{name}: {c.folder} has no "
                            f"{group} (its images gave {', '.join(c.components)}): drop the limit or compare "
                            f"images with caustic, fog and direct layers")
    checks = budget_checks(c.scene, limits, c.metric)
    for check in checks:
        check.name = f"compare.{renderer}.{check.name}"
        check.detail["folder"] = c.folder
        if not check.passed:
            check.message = f"{c.scene}: {check.name} = {check.value:.4g}, limit {check.limit}"
    return checks


def _flicker_budgets(path: str, tables) -> dict:
    """``[animation.NAME]``: scene name → {"component.key": limit} over FLICKER_KEYS."""
    if not isinstance(tables, dict):
        raise GateError(f"{path}: animation = {tables!r}: expected [animation.NAME] tables")
    out = {}
    for name, table in tables.items():
        if not isinstance(table, dict) or not table:
            raise GateError(f"{path}: animation.{name} = {table!r}: expected a table of flicker budgets")
        limits = {}
        for group, values in table.items():
            if group not in COMPONENTS or not isinstance(values, dict):
                raise GateError(f"{path}: animation.{name}.{group}: expected a table named {', '.join(COMPONENTS)}")
            for key, limit in values.items():
                where = f"{path}: animation.{name}.{group}.{key}"
                if key not in FLICKER_KEYS:
                    raise GateError(f"{where}: unknown; expected {', '.join(FLICKER_KEYS)}")
                if isinstance(limit, bool) or not isinstance(limit, (int, float)) or not math.isfinite(limit) \
                        or not limit > 0:
                    raise GateError(f"{where} = {limit!r}: expected a positive number")
                limits[f"{group}.{key}"] = float(limit)
        out[name] = limits
    return out


def flicker_checks(animation: MeasuredAnimation, limits: dict, path: str) -> list:
    """An animation's flicker (``animate``'s output, read back) against its budgets; GateError
    for a budget on a seed mode it did not measure, a NaN, or a limit the noise cannot resolve."""
    scene, checks = animation.scene, []
    for name, limit in limits.items():
        group, key = name.split(".", 1)
        mode = FLICKER_KEYS[key]
        if mode not in animation.seed_modes:
            raise GateError(f"{path}: animation.{scene}.{name} checks the {mode} seed, which "
                            f"{animation.folder} did not measure: rerun animate with both seed modes")
        m = animation.metrics[mode][group]
        value = _number(m.flicker, scene, f"{group} flicker ({mode} seed)")
        se = _or_zero(m.flicker_se)
        if limit < RESOLVE_SIGMAS * se:
            raise GateError(f"{scene}: animation.{scene}.{name} = {limit:g} is tighter than the noise can resolve "
                            f"({RESOLVE_SIGMAS:g} SE = {RESOLVE_SIGMAS * se:.2e}): raise it or animate more chains")
        check = Check(scene, f"over_time.{name}", value, f"≤ {limit:g}", value <= limit,
                      detail={"standard_error": se, "seed_mode": mode, "folder": animation.folder})
        if not check.passed:
            check.message = f"{scene}: over_time.{name} = {value:.4g}, limit {check.limit}"
        checks.append(check)
    return checks


def check_measurable(budgets: dict, names: Iterable[str], params: ApproxParams) -> None:
    """GateError, before anything is measured, for a budget these parameters leave nothing
    to check: segment budgets (step 2) with steps < 2."""
    for name in names:
        segments = [key for key in budgets["scenes"][name] if key.startswith("segments.")]
        if segments and params.steps < 2:
            raise GateError(f"{budgets['path']}: scene.{name}.{segments[0]} checks the step-2 segments, but steps = "
                            f"{params.steps}: set steps ≥ 2, or gate with budgets without segment limits")


def _or_zero(value: float) -> float:
    """A noise figure, 0 where not measured (NaN)."""
    return value if math.isfinite(value) else 0.0


def _number(value, scene, what) -> float:
    if value is None or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise GateError(f"{scene}: {what} is {value!r}: a metric the gate needs is missing or NaN")
    return float(value)


def _step2(segments: list, scene: str) -> dict:
    rows = [r for r in segments if r.get("grouping") == "step" and r.get("step") == 2]
    if not rows:
        raise GateError(f"{scene}: no step-2 segments (steps < 2?): the segment budgets cannot be checked")
    return rows[0]


def budget_checks(scene: str, limits: dict, metric: Callable[[str, str], Estimate], segments: Sequence = ()) -> list:
    """The scene's budgets against its measured metrics (``metric(name, component)``:
    e.g. ``Experiment.metric``) and ``segments`` (the segment records the segment budgets
    read); GateError for a budget the noise cannot resolve or a NaN metric."""
    checks = []
    for name, limit in limits.items():
        group, key = name.split(".", 1)
        if group == "segments":
            row = _step2(list(segments), scene)
            if key == "missed_step2_max":
                missed = sum(row.get(f"count_{c}", 0) + row.get(f"count_beyond_self_rehit_{c}", 0)
                             for c in ("missed_inside", "missed_medium"))
                value = _number(missed / row["segments"], scene, name)
            else:
                value = _number(row["abs_dt_p90"], scene, name)
            checks.append(Check(scene, name, value, f"≤ {limit:g}", value <= limit))
            continue
        if key in RELMSE_KEYS:
            m = metric(RELMSE_KEYS[key], group)
            value = _number(m.debiased, scene, f"{group} {RELMSE_KEYS[key].replace('_', ' ')}")
            se, floor = _or_zero(m.standard_error), _or_zero(m.reference_floor)
            resolvable = floor + RESOLVE_SIGMAS * se
            if limit < resolvable:
                raise GateError(f"{scene}: {name} = {limit:g} is tighter than the noise can resolve (the reference's "
                                f"floor {floor:.2e} + {RESOLVE_SIGMAS:g} SE = {resolvable:.2e}): "
                                f"raise it or render a finer reference / more seeds")
            checks.append(Check(scene, name, value, f"≤ {limit:g}", value <= limit))
        elif key == "energy_ratio":
            m = metric("energy_ratio", group)
            value = _number(m.value, scene, f"{group} energy ratio")
            sigma = _or_zero(m.reference_sigma)
            if (limit[1] - limit[0]) / 2 < RESOLVE_SIGMAS * sigma:
                raise GateError(f"{scene}: {name} = {limit} is narrower than {RESOLVE_SIGMAS:g} σ of the reference's "
                                f"total ({sigma:.2e}): widen it")
            checks.append(Check(scene, name, value, f"in [{limit[0]:g}, {limit[1]:g}]", limit[0] <= value <= limit[1]))
        else:
            value = _number(metric("hdr_flip", group).value, scene, f"{group} HDR-FLIP")
            checks.append(Check(scene, name, value, f"≤ {limit:g}", value <= limit))
    for c in checks:
        if not c.passed:
            c.message = f"{scene}: {c.name} = {c.value:.4g}, limit {c.limit}"
    return checks
