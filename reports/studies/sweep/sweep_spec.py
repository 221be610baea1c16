"""A sweep's specification: a grid over the approximation's parameters, one experiment per point
(run by ``reports.studies.sweep.sweep_run``).

A sweep is given on the command line (``--scenes a,b --vary layers=1,2,4 --set
photon_res=256 --seeds N``) or in a TOML file with the same names::

    scenes = ["bunny", "skull"]      # built-in names or .toml paths
    preset = "quick"                 # the parameters not named below
    seeds = 1
    [vary]                           # the grid: every combination, per scene
    layers = [1, 2, 4, 8]
    iterations = [4, 8, 16, 30]
    [set]                            # fixed parameters
    photon_res = 256
    [reference]                      # optional: the reference budget (report's by default)
    target_noise = "caustic=0.005,fog=0.002,direct=0.002"
    [measurement]                    # optional: the measurement settings (report's by default)
    exact_subphotons = 16

``vary`` may also be an array of tables (``[[vary]]``): several grids, whose points are
joined in order, a point named twice run once (e.g. the variants sweep,
``reports/studies/sweep/variants.toml``: each search with its own knobs). The figures see
every varied name with all its values.

Every name is an ``ApproxParams`` field (docs/approx.md) or a scene field, a dotted path
into the scene file (``medium.sigma_s``, ``light.intensity``, ``specular.0.ior``:
``scenes.fields``), applied to every scene of the sweep and validated as the loader
validates a file. On the command line a scene field's values are numbers or words
(``--vary medium.sigma_s=0.05,0.2``); RGB lists go in a TOML spec. Every point is
validated before anything renders. The reference of each scene (and image size) is rendered once, in
this process, before the points run; workers read it from the cache.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass, field

from volcaustics.approx.params import PRESETS, ApproxParams, ParamError, preset
from volcaustics.experiment.measurement import measurement_settings
from volcaustics.experiment.point_checks import check_frame, check_medium
from volcaustics.experiment.sizing import reference_settings
from volcaustics.infra.errors import InputError
from volcaustics.reports.measuring.results.param_input import parse_assignment, parse_overrides, parse_value
from volcaustics.reports.measuring.results.tomlfile import load_toml
from volcaustics.reports.measuring.runner import Point
from volcaustics.reports.studies.sweep.study_limits import MAX_POINTS
from volcaustics.scenes import BUILTIN_NAMES, SceneError, resolve_scene
from volcaustics.scenes.catalogue import scene_relative_to
from volcaustics.scenes.fields import field_value, is_scene_field, parse_field_value, scene_with

ANIMATE_ONLY = ("temporal", "temporal_weight")  # parameters a sweep point's frames never use
SPEC_KEYS = ("scenes", "preset", "seeds", "vary", "set", "reference", "measurement")
SECONDS_PER_POINT = 25.0  # quick preset, 4 seeds, 2 cores (the variants sweep, docs/decisions.md)


class SweepError(InputError):
    """A sweep specification that cannot run; the message names where, what and the fix."""


@dataclass(frozen=True)
class SweepSpec:
    """scenes: SCENE arguments; vary: ((name, values), ...) in grid order (of all grids:
    every varied name, every value); fixed: name → value; preset: "quick" or "paper";
    seeds per point; reference: settings overrides (REFERENCE_KEYS); grids: the grids
    when there are several (each like ``vary``), else empty; measurement: the
    measurement settings' overrides (``experiment.measurement``)."""

    scenes: tuple
    vary: tuple
    fixed: dict = field(default_factory=dict)
    preset: str = "quick"
    seeds: int = 1
    reference: dict = field(default_factory=dict)
    grids: tuple = ()
    measurement: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        out = {"scenes": list(self.scenes), "vary": {k: list(v) for k, v in self.vary}, "set": dict(self.fixed),
               "preset": self.preset, "seeds": self.seeds, "reference": dict(self.reference),
               "measurement": dict(self.measurement)}
        if self.grids:
            out["grids"] = [{k: list(v) for k, v in grid} for grid in self.grids]
        return out


def spec_from_args(scenes: str | None, vary: list, fixed: list, *, preset: str, seeds: int,
                   max_points: int | None = MAX_POINTS) -> SweepSpec:
    """A spec from ``--scenes a,b``, ``--vary NAME=V1,V2`` and ``--set NAME=V``; more
    than ``max_points`` points (None: no limit) is refused."""
    names = [s.strip() for s in scenes.split(",")] if scenes is not None else list(BUILTIN_NAMES)
    grid: list = []
    for text in vary or []:
        name, values = _assignment(text, "--vary")
        if name in dict(grid):
            raise SweepError(f"--vary {text!r}: {name} is varied twice")
        grid.append((name, tuple(values)))
    scene_fixed = [text for text in fixed or [] if is_scene_field(text.partition("=")[0])]
    settled = parse_overrides([t for t in fixed or [] if t not in scene_fixed], seed_option=False)
    for text in scene_fixed:
        name, values = _assignment(text, "--set")
        if len(values) != 1 or name in settled:
            raise SweepError(f"--set {text!r}: one value per field, set once (a sweep varies with --vary)")
        settled[name] = values[0]
    return checked_spec(SweepSpec(tuple(names), tuple(grid), settled, preset, seeds), "command line", max_points)


def spec_scenes(doc: dict, path: str, given: list | None = None) -> list:
    """A spec file's ``scenes`` (default every built-in), paths relative to the file, or
    ``given`` (``--scenes``, relative to the working folder) in their place: the one rule
    for grid and best specs. SweepError for anything but a non-empty list of strings."""
    if given is not None:
        return list(given)
    scenes = doc.get("scenes")
    if scenes is None:
        return list(BUILTIN_NAMES)
    if not isinstance(scenes, list) or not scenes or not all(isinstance(s, str) for s in scenes):
        raise SweepError(f"{path}: scenes = {scenes!r}: expected a non-empty list of scene names or paths "
                         f'(e.g. scenes = ["sphere1"])')
    return [scene_relative_to(s, path) for s in scenes]


def spec_from_toml(path: str, max_points: int | None = MAX_POINTS, scenes: list | None = None) -> SweepSpec:
    """A spec from a TOML file (see the module's docstring); ``scenes`` (``--scenes``)
    replaces its scenes; more than ``max_points`` points (None: no limit) is refused."""
    return spec_from_document(load_toml(path, keys=SPEC_KEYS, what="sweep spec"), path, max_points, scenes)


def spec_from_document(doc: dict, path: str, max_points: int | None = MAX_POINTS,
                       scenes: list | None = None) -> SweepSpec:
    """A spec from a spec file's tables (a parsed TOML file, or ``vc.sweep``'s arguments
    laid out as one), checked as a file's are; ``path`` names it in errors and anchors its
    relative scene paths."""
    scenes = spec_scenes(doc, path, scenes)
    tables = doc.get("vary", {})
    several = isinstance(tables, list)
    if several and (not tables or not all(isinstance(t, dict) for t in tables)):
        raise SweepError(f"{path}: vary = {tables!r}: expected a table [vary] or tables [[vary]]")
    grids = []
    for k, table in enumerate(tables if several else [_table(doc, "vary", path)]):
        where = f"vary[{k}]" if several else "vary"
        axes = []
        for name, values in table.items():
            _unquoted(name, values, f"{path}: {where}")
            if not isinstance(values, list) or not values:
                raise SweepError(f"{path}: {where}.{name} = {values!r}: expected a non-empty list")
            axes.append((name, tuple(_value(name, v, f"{path}: {where}") for v in values)))
        grids.append(tuple(axes))
    grid = _merged(grids)
    settled = {}
    for name, v in _table(doc, "set", path).items():
        _unquoted(name, v, f"{path}: set")
        settled[name] = _value(name, v, f"{path}: set")
    reference = _table(doc, "reference", path)
    try:
        reference_settings(reference)  # checked now
    except InputError as exc:
        raise SweepError(f"{path}: {exc}") from None
    measurement = _table(doc, "measurement", path)
    seeds = doc.get("seeds", 1)
    preset = doc.get("preset", "quick")
    return checked_spec(SweepSpec(tuple(scenes), grid, settled, preset, seeds, dict(reference),
                              tuple(grids) if several else (), dict(measurement)), path, max_points)


def _hinted(exc: InputError, name: str) -> InputError:
    """``exc``, with the scene fields named when it is about an unknown parameter."""
    if "unknown parameter" not in str(exc):
        return exc
    return SweepError(f"{exc}; or a scene field, a dotted path into the scene file such as medium.{name}, "
                      f"light.{name} or specular.0.{name}")


def _unquoted(name: str, value, where: str) -> None:
    """SweepError for a table where a value belongs: TOML read ``medium.sigma_s = …``
    (unquoted) as the table ``medium``; a scene field is one quoted key."""
    if isinstance(value, dict) and not is_scene_field(name):
        inner = next(iter(value), "KEY")
        raise SweepError(f"{where}.{name}: a table; a scene field is one quoted key, e.g. "
                         f"\"{name}.{inner}\" = ... (unquoted, TOML reads {name}.{inner} as a table)")


def _value(name: str, value, where: str):
    """A parameter's or a scene field's value (text or TOML), typed; SweepError naming ``where``."""
    if not is_scene_field(name):
        try:
            return parse_value(name, value, where)
        except ParamError as exc:
            raise _hinted(exc, name) from None
    try:
        return parse_field_value(name, value)  # hashable (a list as a tuple): a point's identity
    except SceneError as exc:
        raise SweepError(f"{where}: {exc}") from None


def _assignment(text: str, where: str) -> tuple:
    """``NAME=V1,V2``: a parameter's (``parse_assignment``) or a scene field's values."""
    name, sep, values = text.partition("=")
    if not is_scene_field(name.strip()):
        try:
            return parse_assignment(text, where)
        except ParamError as exc:
            raise _hinted(exc, name.strip()) from None
    items = values.split(",")
    if not sep or any(not v.strip() for v in items):
        raise SweepError(f"{where} {text!r}: expected NAME=VALUE[,VALUE...] (RGB lists go in a TOML spec)")
    return name.strip(), [_value(name.strip(), v, f"{where} {text!r}") for v in items]


def _merged(grids: list) -> tuple:
    """Every varied name of ``grids`` (first-seen order) with all its values."""
    merged: dict = {}
    for grid in grids:
        for name, values in grid:
            merged.setdefault(name, [])
            merged[name] += [v for v in values if v not in merged[name]]
    return tuple((name, tuple(values)) for name, values in merged.items())


def _table(doc, key, path) -> dict:
    value = doc.get(key, {})
    if not isinstance(value, dict):
        raise SweepError(f"{path}: {key} = {value!r}: expected a table [{key}]")
    return value


def grid_size(spec: SweepSpec) -> int:
    """The points of the spec's grids over its scenes, before a point named twice is
    merged (counted, not expanded)."""
    return len(spec.scenes) * sum(math.prod(len(values) for _, values in grid) for grid in spec.grids or (spec.vary,))


def checked_spec(spec: SweepSpec, where: str, max_points: int | None = MAX_POINTS) -> SweepSpec:
    """Validate everything that can be checked before rendering: the grid's size, scenes
    exist, names, the preset, the seeds, the measurement settings, every point's parameters,
    overlaps of vary and set."""
    if spec.preset not in PRESETS:
        raise SweepError(f"{where}: preset = {spec.preset!r}: expected {' or '.join(repr(n) for n in PRESETS)}")
    if isinstance(spec.seeds, bool) or not isinstance(spec.seeds, int) or not 1 <= spec.seeds <= 1024:
        raise SweepError(f"{where}: seeds = {spec.seeds!r}: expected an integer in [1, 1024]")
    if not isinstance(spec.measurement, dict):
        raise SweepError(f"{where}: measurement = {spec.measurement!r}: expected a table [measurement]")
    measurement_settings(spec.measurement, where=f"{where}: measurement")
    if not spec.scenes or any(not s for s in spec.scenes):
        raise SweepError(f"{where}: scenes = {list(spec.scenes)!r}: expected at least one scene, none empty")
    if len(set(spec.scenes)) != len(spec.scenes):
        raise SweepError(f"{where}: scenes = {list(spec.scenes)!r}: a scene is listed twice")
    for grid in spec.grids or (spec.vary,):
        for name, values in grid:
            if len(set(values)) != len(values):
                raise SweepError(f"{where}: vary.{name} = {list(values)!r}: a value is listed twice")
    size = grid_size(spec)
    if max_points is not None and size > max_points:
        days = size * SECONDS_PER_POINT / 86400.0
        raise SweepError(f"{where}: {size:,} points (scenes × grid), more than {max_points:,}: about {days:,.0f} days "
                         f"at {SECONDS_PER_POINT:g} s a point; narrow the grid, or pass --yes to run it")
    both = sorted(set(dict(spec.vary)) & set(spec.fixed))
    if both:
        raise SweepError(f"{where}: {both[0]} is both varied and set")
    if "seed" in dict(spec.vary):
        raise SweepError(f"{where}: seed cannot be varied; use seeds = N (points with seeds seed … seed + N − 1)")
    for name in ANIMATE_ONLY:
        if name in dict(spec.vary):  # a sweep point is one scene's frames: its values would be identical points
            raise SweepError(f"{where}: vary.{name}: {name} acts only over an animation's frames (volcaustics "
                             f"animate), so every value would measure the same point")
    every = points(spec)
    for scene, fields in sorted({(p.scene, p.fields) for p in every}, key=str):
        try:  # every scene as measured, a changed one validated as the loader validates a file
            measured = scene_with(scene, fields) if fields else resolve_scene(scene)
        except SceneError as exc:
            raise SweepError(f"{where}: {exc}") from None
        label = f"{where}: {dict(fields)}" if fields else where
        try:
            check_medium(measured)
        except InputError as exc:
            raise SweepError(f"{label}: {exc}") from None
    for point in every:
        last = point.params.seed + spec.seeds - 1
        if last > 2**32 - 1:
            raise SweepError(f"{where}: seed {point.params.seed} with seeds = {spec.seeds} exceeds 2^32 − 1")
        try:  # what a frame allocates and dispatches and a measurement holds, before any reference renders
            check_frame(point.params, spec.seeds)
        except ParamError as exc:
            raise SweepError(f"{where}: point {point.scene}: {exc}") from None
    return spec


def _own_values(scene: str, names: list) -> dict:
    """The values the scene ``scene`` has of the fields ``names`` (``scenes.fields.field_value``)."""
    try:
        model = resolve_scene(scene)
    except SceneError as exc:
        raise SweepError(str(exc)) from None
    values = {name: field_value(model, name) for name in names}
    return {name: value for name, value in values.items() if value is not None}


def points(spec: SweepSpec, cls: type = ApproxParams) -> list:
    """Every point of the grid (``reports.measuring.runner.Point``), per scene, in grid order
    (ParamError → SweepError). With a preset that takes values from the scene, each point
    takes them unless set or varied: layers from its depth complexity
    (``approx.params.AUTO_LAYERS``), then photon_res matched to the paper configuration's
    frame on its scene (AUTO_PHOTON_RES; ``reports.measuring.cost_match.with_auto_values``, as
    every command does; a point's scene fields are not in the match)."""
    from volcaustics.approx.params import AUTO_LAYERS, AUTO_PHOTON_RES

    varied = {name for grid in (spec.grids or (spec.vary,)) for name, _ in grid}
    given = "photon_res" in spec.fixed or "photon_res" in varied
    layers_given = "layers" in spec.fixed or "layers" in varied
    auto = (spec.preset in AUTO_PHOTON_RES and not given) or (spec.preset in AUTO_LAYERS and not layers_given)
    fixed = {k: v for k, v in spec.fixed.items() if not is_scene_field(k)}
    fixed_fields = {k: v for k, v in spec.fixed.items() if is_scene_field(k)}
    try:
        base = preset(spec.preset, cls, **fixed)
    except ParamError as exc:
        raise SweepError(f"set: {exc}") from None
    out, seen = [], set()
    varied_fields = [name for name, _ in spec.vary if is_scene_field(name)]
    for scene in spec.scenes:
        # a field another grid varies keeps the scene's own value here (a column, not NaN)
        own = _own_values(scene, varied_fields) if spec.grids else {}
        for grid in spec.grids or (spec.vary,):
            names = [name for name, _ in grid]
            for combo in itertools.product(*(values for _, values in grid)):
                changes = {k: v for k, v in zip(names, combo) if not is_scene_field(k)}
                fields = tuple(sorted({**own, **fixed_fields, **{k: v for k, v in zip(names, combo)
                                                                 if is_scene_field(k)}}.items()))
                try:
                    params = dataclasses.replace(base, **changes)
                except ParamError as exc:
                    raise SweepError(f"point {scene}, {changes}: {exc}") from None
                if auto:
                    from volcaustics.reports.measuring.cost_match import with_auto_values

                    params = with_auto_values(scene, params, spec.preset, given, layers_given=layers_given)
                if (scene, params, fields) not in seen:
                    seen.add((scene, params, fields))
                    out.append(Point(scene, params, spec.seeds, fields))
    return out
