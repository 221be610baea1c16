"""The approximation's parameters, declared once (docs/architecture.md).

Each :class:`Param` of :data:`PARAMS` states its name (as everywhere: CLI, tables,
sweeps, plots), type, range or choices, unit, help, default, and how it reaches the
shaders: as a ``define`` of one program (it selects the program: a new value compiles
another) or as a ``uniform`` (set per frame), or neither (``host``: the Python side
uses it, e.g. to size a dispatch). From the table come :class:`ApproxParams`
(validation in its constructor), every command's flags and the sweep's value parsing
(``reports.measuring.results.param_input``), figure labels (:func:`label`) and the programs' cache
keys (:func:`defines`). Adding a parameter is a table entry and the code that uses it.
"""

from __future__ import annotations

import dataclasses
import struct
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Callable, ClassVar, TypeVar, cast, overload

from volcaustics.infra.errors import InputError
from volcaustics.scenes.rng import FRESNEL_MODES, stochastic_fresnel

from .splat_modes import SPLAT_MODES, splat_help, splat_mode

if TYPE_CHECKING:
    from typing import Self

    from volcaustics.scenes.model import Scene


class ParamError(InputError):
    """A parameter value is out of range; the message names it and what is allowed."""


@dataclass(frozen=True)
class Param:
    """One approximation parameter.

    kind        int, float or str
    default     the paper's value (Wang, Wang & Chen); None for width/height: the scene camera's
    help        one line for ``--help`` and the README
    unit        "" when dimensionless
    low, high   inclusive range of an int; open range (low, high) of a float
    choices     the allowed names of a str parameter
    unset       what None means (None: not allowed)
    program     the shader program the define selects ("trace", "fog"), with ``glsl`` "define"
    glsl        "define", "uniform" or "host"
    to_defines  value → the program's #defines (default: {NAME_IN_CAPITALS: value})
    exact       False: the error decomposition's exact images do not depend on it (how the
                approximation searches): they are reused across its values
                (``experiment.exact_store``)
    """

    name: str
    kind: type
    default: object
    help: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    choices: tuple = ()
    unset: str | None = None
    program: str | None = None
    glsl: str = "host"
    to_defines: Callable | None = None
    exact: bool = True

    def expected(self) -> str:
        """What a value must be, as error messages and ``--help`` say it."""
        if self.choices:
            return " or ".join(f'"{c}"' for c in self.choices)
        if self.kind is float:
            text = f"a number in ({self.low:g}, {self.high:g})" + (f" {self.unit}" if self.unit else "")
        else:
            text = f"an integer in [{self.low}, {self.high}]"
        return text + (f" (or unset: {self.unset})" if self.unset else "")

    def check(self, value: object) -> None:
        """Raise ParamError unless ``value`` is allowed."""
        if value is None and self.unset:
            return
        if self.choices:
            ok = value in self.choices
        elif self.kind is float:
            low, high = cast(float, self.low), cast(float, self.high)  # a number parameter has both
            ok = (isinstance(value, (int, float)) and not isinstance(value, bool) and low < value < high
                  and low < float32(value) < high)  # as the shaders get it, too
        else:
            low, high = cast(float, self.low), cast(float, self.high)
            ok = isinstance(value, int) and not isinstance(value, bool) and low <= value <= high
        if not ok:
            raise ParamError(f"{self.name} = {value!r}: expected {self.expected()}")

    def parse(self, text: object) -> int | float | str:
        """A value from command-line text or a TOML value, typed as declared (ParamError
        naming what is expected otherwise; the range is checked by :meth:`check`)."""
        if isinstance(text, str):
            text = text.strip()
        try:
            if self.kind is int:
                if isinstance(text, bool) or (isinstance(text, float) and not text.is_integer()):
                    raise ValueError
                return int(cast("str | float", text))  # any other value: TypeError, caught below
            if self.kind is float:
                if isinstance(text, bool):
                    raise ValueError
                return float(cast("str | float", text))
        except (TypeError, ValueError):
            raise ParamError(f"{self.name} = {text!r}: expected {self.expected()}") from None
        if not isinstance(text, str) or not text:
            raise ParamError(f"{self.name} = {text!r}: expected {self.expected()}")
        return text

    def defines(self, value: object) -> dict:
        """The #defines this value gives its program (``glsl`` "define" only)."""
        return self.to_defines(value) if self.to_defines else {self.name.upper(): value}

    def label(self) -> str:
        """Axis label: the name, with the unit when it has one."""
        return f"{self.name} ({self.unit})" if self.unit else self.name


# The least a float parameter may be (its open range's low end): 1e-6, so that what the
# shaders make of it stays in float32's range and resolution. A kernel σ of 1e-6 m is about
# what float32 resolves of a position 4 m away (its ulp: 4.8e-7 m), and σ² a normal number
# (at 1e-38 it was 0: the caustic was NaN; at 1e-30, too narrow for any pixel centre, 0);
# splat_footprints × a footprint is such a σ; temporal_weight's history weight 1 − w is
# 1 in float32 below w = 6e-8 (the average would never move).
FLOAT32_FLOOR = 1e-6

_DECLARED: tuple = (  # one entry per ApproxParams field, in its order
    Param("photon_res", int, 1500, "photon map resolution N: one photon per covered texel of N²", "texels per side",
          1, 8192),
    Param("layers", int, 4, "light-map levels, each a front-face and a back-face map", "", 1, 8, program="trace",
          glsl="define", to_defines=lambda v: {"MAPS": 2 * v}, exact=False),
    Param("layer_strategy", str, "threshold", "threshold (paper §4.2: levels beyond uniform thresholds along the "
          "spot axis) or peel (depth peeling per facing)", choices=("threshold", "peel"), exact=False),
    Param("iterations", int, 30, "binary-search iterations per detected crossing", "", 0, 64, program="trace",
          glsl="define", exact=False),
    Param("peak_samples", int, 8, "samples per segment and map to find the first sign change", "", 0, 256,
          program="trace", glsl="define", exact=False),
    Param("search", str, "bisection", "how a segment's first crossing is found on one map: bisection (paper §4.1: "
          "peak_samples uniform samples, then iterations halvings), secant (the same samples, then regula falsi), "
          "dda (every texel the segment crosses: exact at the maps' resolution) or hiz (dda skipping min-max "
          "pyramid cells)", choices=("bisection", "secant", "dda", "hiz"), program="trace", glsl="define",
          to_defines=lambda v: {f"SEARCH_{v.upper()}": 1}, exact=False),
    Param("start_rule", str, "offset", "how a segment avoids re-finding the surface it leaves: offset (start the "
          "search a few texel footprints out), id (the maps carry primitive ids; crossings onto the start "
          "triangle are passed over) or facing (crossings onto faces the photon cannot meet from its side, "
          "outside along their outward normal or inside against it, are passed over)",
          choices=("offset", "id", "facing"), program="trace", glsl="define",
          to_defines=lambda v: {"START_RULE_ID": 1} if v == "id" else {"START_RULE_FACING": 1} if v == "facing"
          else {}, exact=False),
    Param("crossing", str, "sign", "what a search takes for a crossing: sign (paper: any change of sign of f "
          "between covered points) or surface (only where the segment is at the crossed texel's surface, within "
          "2 footprints · (1 + tan θ) of its distance: a change of sign between texels of two surfaces is passed "
          "over, like a screen-space ray tracer's thickness test)", choices=("sign", "surface"), program="trace",
          glsl="define", to_defines=lambda v: {"CROSSING_SURFACE": 1, "CROSSING_TEXELS": "2.0"} if v == "surface"
          else {}, exact=False),
    Param("steps", int, 4, "interaction steps (photon maps) traced", "", 1, 32),
    # float bounds hold in float32, where the shaders take them (FLOAT32_FLOOR)
    Param("splat_radius", float, 0.01, "standard deviation of the splatted 3D Gaussian", "m", FLOAT32_FLOOR, 10,
          glsl="uniform"),
    Param("splat", str, "fixed", splat_help(),
          choices=tuple(SPLAT_MODES),
          program="trace",
          glsl="define", to_defines=lambda v: {f"SPLAT_{v.upper()}": 1} if v != "fixed" else {}),
    Param("splat_neighbours", int, 16, "density splats: the photons a kernel's σ-disc holds on average", "", 1,
          4096, glsl="uniform"),
    Param("splat_footprints", float, 4.0, "adaptive splats and differential beams: the kernel's standard deviation "
          "in photon footprints", "", FLOAT32_FLOOR, 100, glsl="uniform"),
    Param("beam_width", str, "fixed", "beams' kernel width: fixed (splat_radius along every beam) or differential "
          "(splat_footprints × the photon's ray-differential footprint, which changes linearly along the beam at "
          "the rate the differential carries, within [splat_radius/16, 4·splat_radius]: beams widen where the "
          "light spreads and narrow where it focuses) or balanced (the differential width times a factor in "
          "[1/8, 1] that balances the kernel's blur against its noise along the beam, from a pilot of the "
          "step's beams at 1/16 of the pixels: its curvature against the noise between two halves of its "
          "beams); other splat modes ignore it",
          choices=("fixed", "differential", "balanced"), program="trace", glsl="define",
          to_defines=lambda v: {"BEAM_DIFFERENTIAL": 1, **({"BEAM_BALANCED": 1} if v == "balanced" else {})}
          if v != "fixed" else {}),
    Param("emission", str, "uniform", "where photons start: uniform (paper: one per covered texel of the photon "
          "map) or adaptive (the photon_res² photons drawn over the texels in proportion to their power times 1 + "
          "3 where the surface turns sharply or breaks, each weighted by 1/its expected count: unbiased)",
          choices=("uniform", "adaptive"), program="trace", glsl="define",
          to_defines=lambda v: {"EMISSION_ADAPTIVE": 1} if v == "adaptive" else {}),
    Param("emission_jitter", str, "center", "where in its texel a photon starts: center (paper), random (a uniformly "
          "random point, new each seed) or sobol (an Owen-scrambled Sobol point of the texel's Morton index, a new "
          "scramble each seed: stratified over every aligned block of texels). Adaptive emission's photons start "
          "at a random point unless sobol (several may share a texel)", choices=("center", "random", "sobol"),
          program="trace", glsl="define",
          to_defines=lambda v: {f"EMISSION_JITTER_{v.upper()}": 1} if v != "center" else {}),
    Param("denoise", str, "none", "none (paper) or oidn: Intel Open Image Denoise on the caustic and fog layers, "
          "guided by the G-buffer's albedo and normal; its time and pixels are reported beside the frame cost, "
          "never in it", choices=("none", "oidn"), exact=False),
    Param("temporal", str, "none", "none (paper: every frame on its own) or ema: animate accumulates the caustic "
          "and fog over frames, a new seed each, by an exponential moving average whose history is rejected where "
          "the G-buffer changed, reset when the light jumps and clipped to the frame's neighbourhood "
          "(approx.temporal; a still frame has no history)", choices=("none", "ema"), exact=False),
    Param("temporal_weight", float, 0.25, "ema: the current frame's weight w (noise variance → w/(2 − w))", "",
          FLOAT32_FLOOR, 1, exact=False),
    Param("light_res", int, 1024, "resolution of the light layer maps and the shadow map", "texels per side", 16,
          8192, glsl="uniform", exact=False),
    Param("width", int, None, "image width", "pixels", 1, 16384, unset="the scene's"),
    Param("height", int, None, "image height", "pixels", 1, 16384, unset="the scene's"),
    Param("fog_steps", int, 64, "ray-marching samples of the fog integral per pixel", "", 1, 4096, program="fog",
          glsl="define", exact=False),
    Param("march_steps", int, 16, "heterogeneous media: midpoint samples of the density along each photon "
          "segment (and from the light to the first surface) for its transmittance", "", 1, 1024, glsl="uniform"),
    Param("light_volume_res", int, 128, "heterogeneous media: columns per side of the light's transmittance "
          "volume (the optical depth from the light through its frustum: the fog's and direct light's light "
          "side)", "texels per side", 2, 2048, glsl="uniform"),
    Param("light_volume_slices", int, 64, "heterogeneous media: distances per column of the light's "
          "transmittance volume", "", 2, 1024, glsl="uniform"),
    Param("camera_volume_res", int, 128, "heterogeneous media: columns per side of the camera's transmittance "
          "volume (froxels: the optical depth from the eye, the eye's side of fog, direct light and splats)",
          "texels per side", 2, 2048, glsl="uniform"),
    Param("camera_volume_slices", int, 64, "heterogeneous media: distances per column of the camera's "
          "transmittance volume", "", 2, 1024, glsl="uniform"),
    Param("fresnel", str, "deterministic", "deterministic (refracted power × (1 − R)), stochastic (choose by R) or "
          "stratified (choose by R with numbers stratified over the photons: neighbours split in proportion to R, "
          "scenes.rng.stratified)", choices=FRESNEL_MODES, program="trace", glsl="define",
          to_defines=lambda v: {"FRESNEL_STOCHASTIC": 1, **({"FRESNEL_STRATIFIED": 1} if v == "stratified" else {})}
          if stochastic_fresnel(v) else {}),
    Param("fresnel_splits", int, 0, "the first interactions along the refracted chain at which every photon "
          "splits in two, reflected at R of its power and refracted at 1 − R, before fresnel chooses "
          "(scenes.splitting: fresnel_splits + 1 batches of photon_res² photons)", "", 0, 4, program="trace",
          glsl="define", to_defines=lambda v: {"FRESNEL_SPLITS": v} if v else {}),
    Param("split_every", int, 1, "fresnel_splits: one photon in this many traces each reflected branch, at as "
          "many times its power (stratified over the texels; scenes.splitting.kept)", "", 1, 64, program="trace",
          glsl="define", to_defines=lambda v: {"SPLIT_EVERY": v} if v > 1 else {}),
    Param("seed", int, 0, "seed of the shared RNG", "", 0, 2**32 - 1, glsl="uniform"),
)


class ParamsMethods:
    """What every parameters class has besides its fields (:class:`ApproxParams`, and a
    :func:`params_class` of another table): validation on construction, the scene's size
    filled in, a plain dict, the names in order."""

    TABLE: ClassVar[tuple] = ()
    if TYPE_CHECKING:  # every parameters class is a dataclass of (at least) these fields
        __dataclass_fields__: ClassVar[dict[str, Any]]
        width: int | None
        height: int | None

    def __post_init__(self) -> None:
        for param in self.TABLE:
            param.check(getattr(self, param.name))

    def resolved(self, scene: Scene) -> Self:
        """The parameters with width/height filled from the scene camera."""
        return replace(self, width=self.width or scene.camera.width,
                       height=self.height or scene.camera.height)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def names(cls) -> list:
        return [p.name for p in cls.TABLE]


_BY_NAME = {p.name: p for p in _DECLARED}


def float32(value: float) -> float:
    """``value`` rounded to float32, as a shader's uniform holds it (within float32's range)."""
    return float(struct.unpack("f", struct.pack("f", value))[0])


def declared(name: str) -> Any:
    """The field of parameter ``name`` of :data:`_DECLARED`: its default, and the
    :class:`Param` as the field's metadata ``"param"``."""
    return field(default=_BY_NAME[name].default, metadata={"param": _BY_NAME[name]})


@dataclass(frozen=True)
class ApproxParams(ParamsMethods):
    """The approximation's parameters (paper defaults): one field per :class:`Param`,
    which the field carries as its metadata ``"param"``; validated on construction."""

    photon_res: int = declared("photon_res")
    layers: int = declared("layers")
    layer_strategy: str = declared("layer_strategy")
    iterations: int = declared("iterations")
    peak_samples: int = declared("peak_samples")
    search: str = declared("search")
    start_rule: str = declared("start_rule")
    crossing: str = declared("crossing")
    steps: int = declared("steps")
    splat_radius: float = declared("splat_radius")
    splat: str = declared("splat")
    splat_neighbours: int = declared("splat_neighbours")
    splat_footprints: float = declared("splat_footprints")
    beam_width: str = declared("beam_width")
    emission: str = declared("emission")
    emission_jitter: str = declared("emission_jitter")
    denoise: str = declared("denoise")
    temporal: str = declared("temporal")
    temporal_weight: float = declared("temporal_weight")
    light_res: int = declared("light_res")
    width: int | None = declared("width")
    height: int | None = declared("height")
    fog_steps: int = declared("fog_steps")
    march_steps: int = declared("march_steps")
    light_volume_res: int = declared("light_volume_res")
    light_volume_slices: int = declared("light_volume_slices")
    camera_volume_res: int = declared("camera_volume_res")
    camera_volume_slices: int = declared("camera_volume_slices")
    fresnel: str = declared("fresnel")
    fresnel_splits: int = declared("fresnel_splits")
    split_every: int = declared("split_every")
    seed: int = declared("seed")


#: The parameter table: the fields' Params, in the fields' order (the one declaration).
PARAMS: tuple = tuple(f.metadata["param"] for f in dataclasses.fields(ApproxParams))
ApproxParams.TABLE = PARAMS
if [p.name for p in PARAMS] != [p.name for p in _DECLARED]:
    raise AssertionError("ApproxParams: its fields and the declared parameters differ")


def params_class(table: tuple = PARAMS, name: str = "ApproxParams") -> type:
    """A frozen dataclass with one field per parameter of ``table`` (defaults from it),
    validated on construction, with :class:`ParamsMethods`: a table other than
    :data:`PARAMS` (a parameter being added; :class:`ApproxParams` is declared in source)."""
    cls = dataclasses.make_dataclass(
        name, [(p.name, p.kind if p.unset is None else p.kind | None,
                field(default=p.default, metadata={"param": p})) for p in table],
        bases=(ParamsMethods,), frozen=True, namespace={"TABLE": table})
    cls.__module__ = __name__  # picklable by name (what make_dataclass does from Python 3.12 on)
    cls.__doc__ = f"The approximation's parameters (paper defaults; {', '.join(p.name for p in table)})."
    return cls


def param(name: str, table: tuple = PARAMS) -> Param:
    """The table's entry ``name`` (ParamError listing the names otherwise)."""
    for p in table:
        if p.name == name:
            return p
    raise ParamError(f"unknown parameter {name!r}; expected one of {', '.join(p.name for p in table)}")


def defines(params: ParamsMethods, program: str) -> dict:
    """The #defines that ``params`` give ``program`` ("trace", "fog"): what selects a
    compiled program, so also its cache key."""
    out = {}
    for p in params.TABLE:
        if p.glsl == "define" and p.program == program:
            out.update(p.defines(getattr(params, p.name)))
    return out


def differential_beams(params: ParamsMethods) -> bool:
    """Whether ``params`` draw beams as wide as their photons' ray differentials (splat =
    beams, beam_width = differential, or balanced: scaled by a pilot): the one test of it."""
    return splat_mode(params).beams and getattr(params, "beam_width", "fixed") != "fixed"


def balanced_beams(params: ParamsMethods) -> bool:
    """Whether ``params``' beam widths are balanced by a pilot (splat = beams, beam_width =
    balanced: approx.splat.Splatter.balance_map)."""
    return splat_mode(params).beams and getattr(params, "beam_width", "fixed") == "balanced"


def photon_slots(params: ApproxParams) -> int:
    """The photon slots a frame of ``params`` traces: photon_res² per batch, fresnel_splits
    + 1 batches (``scenes.splitting``)."""
    return (params.fresnel_splits + 1) * params.photon_res**2


def carries_differentials(params: ParamsMethods) -> bool:
    """Whether ``params``' photons carry ray differentials (common/differential.glsl):
    their kernels come from them (splat = adaptive, or :func:`differential_beams`)."""
    return splat_mode(params).differential_width or differential_beams(params)


def label(name: str) -> str:
    """A column's axis label: a parameter's name with its unit, else the name."""
    try:
        return param(name).label()
    except ParamError:
        return name


# The presets, one meaning in every command (docs/approx.md, its paragraph "Presets"): what each changes from
# the table's defaults. paper: the paper's parameters at its image size (800×800, Table 1);
# quick: small enough for tests and the report on 2 cores.
PRESET_VALUES: dict[str, dict[str, object]] = {
    "paper": {"width": 800, "height": 800},
    "quick": {"photon_res": 256, "light_res": 256, "width": 256, "height": 256, "fog_steps": 48, "splat_radius": 0.02},
}
# best: the configuration the one-frame search adopted (docs/decisions.md "The one-frame
# search"), at the quick preset's size; its photon_res is matched to the paper
# configuration's frame cost on the scene at hand (AUTO_PHOTON_RES: the commands do it,
# ``reports.measuring.cost_match``), unless --photon-res is given
BEST = {"splat": "density", "splat_neighbours": 4, "fresnel": "stochastic", "steps": 4, "layers": 2}
PRESET_VALUES["best"] = {**PRESET_VALUES["quick"], **BEST}
# beams: the preset best with its density splats replaced by photon beams (splat = beams),
# each as wide as its photon's ray-differential footprint (beam_width = differential, one
# footprint, within [splat_radius/16, 4·splat_radius]), its Fresnel choices stratified over
# the photons, 8 steps: what the one-frame search measured best for beams on the built-ins,
# judged on the held-out scenes (docs/decisions.md "Points against beams"); every photon
# split at its first two interactions along the refracted chain, each reflected branch
# traced by one photon in two (docs/decisions.md "Splitting at the first surfaces",
# chosen on dense_forward); its photon_res is matched to the paper configuration's cost
# as best's
BEAMS = {"splat": "beams", "beam_width": "differential", "splat_footprints": 1.0, "splat_radius": 0.01,
         "fresnel": "stratified", "steps": 8, "layers": 2, "fresnel_splits": 2, "split_every": 2}
PRESET_VALUES["beams"] = {**PRESET_VALUES["quick"], **BEAMS}
AUTO_PHOTON_RES = {"best": "quick", "beams": "quick"}  # preset → the preset whose frame cost its photon_res matches
# the presets whose layers come from the scene (layers = auto, reports.measuring.cost_match.auto_layers:
# the peeled light-map levels that hold ≥ 5% of the first level's texels, approx.layers),
# unless --layers is given (docs/decisions.md "Layers from the scene")
AUTO_LAYERS: tuple[str, ...] = ("best", "beams")


_P = TypeVar("_P", bound=ParamsMethods)


@overload
def preset(name: str, cls: type[ApproxParams] = ..., /, **changes: object) -> ApproxParams: ...
@overload
def preset(name: str, cls: type[_P], /, **changes: object) -> _P: ...
def preset(name: str, cls: type[ParamsMethods] = ApproxParams, /, **changes: object) -> ParamsMethods:
    """The preset ``name`` as ``cls`` (a :func:`params_class`) with ``changes``
    (ParamError for an unknown preset, an unknown parameter or a bad value; ``name`` and
    ``cls`` are positional, so a parameter of either name is refused as unknown)."""
    if not isinstance(name, str) or name not in PRESET_VALUES:
        raise ParamError(f"preset = {name!r}: expected {' or '.join(repr(n) for n in PRESET_VALUES)}")
    for key in changes:
        param(key, cls.TABLE)  # an unknown name: ParamError listing the table's, not a TypeError
    return cls(**{**PRESET_VALUES[name], **changes})


PRESETS = {name: preset(name) for name in PRESET_VALUES}
QUICK = PRESETS["quick"]
PAPER = PRESETS["paper"]
