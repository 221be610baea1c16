"""A frame's predicted time from its counted work: per pass, a weighted sum of the counts
that a parameter scales (``approx.cost``), with weights fitted to measured pass times
(``bench/cost_model.py``) and kept as data with their provenance, one file per machine
kind in ``approx/cost_weights/`` (docs/concepts/equal-cost.md "The cost model").

A weight set's units are its machine's seconds (``unit`` in its file says so); a set
anchored in other figures (the paper's GPU pass shares) may be in relative units: only
ratios between configurations are compared across sets.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import special_file_kind

from .cost import MEDIUM_PARTS, TIMED_PASSES
from .params import balanced_beams, differential_beams, param, photon_slots
from .splat_modes import SPLAT_MODES

if TYPE_CHECKING:
    from .params import ApproxParams

WEIGHTS_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cost_weights")
#: the passes a frame's time is split into: the GPU passes and ``other`` (the host's share of
#: the frame: reading images back, dispatch)
MODEL_PASSES = (*TIMED_PASSES, "other")


#: the splat mode of differential beams (splat = beams, beam_width = differential) in a weight
#: set's ``splat_modes``: their fragments have a weight of their own
DIFFERENTIAL_BEAMS = "beams/differential"


def splat_mode(params: ApproxParams) -> str:
    """What a weight set must have measured to price a frame of ``params``: its splat mode,
    DIFFERENTIAL_BEAMS for beams with beam_width = differential."""
    if differential_beams(params):
        return DIFFERENTIAL_BEAMS
    return params.splat


def features(cost: dict, params: ApproxParams) -> dict:
    """pass → {feature: value}: the counts each pass's time is modelled on, from a frame's
    cost (``approx.cost.frame_cost``, its ``fragments_*`` counted) and its resolved
    parameters. ``calls``: the pass's dispatches or draws (a fixed cost each);
    ``invocations``: compute invocations launched (every photon slot per dispatch, alive or
    not: ``params.photon_slots``);
    ``maps``, ``texels``: the light maps drawn and their texels (cleared and packed);
    ``medium_reads``: a heterogeneous medium's reads in the pass (``approx.cost``'s
    ``medium_reads_<pass>``; the ``volumes`` pass's are its volumes' texels), and
    ``medium_fragments`` a beam's fragments there (what each costs beside its march)."""
    launched = float(photon_slots(params))
    steps = float(params.steps)
    pixels = float(cast(int, params.width) * cast(int, params.height))  # resolved: both set
    density = SPLAT_MODES[params.splat].density_pass
    beams = SPLAT_MODES[params.splat].beams  # a beam's fragment costs what its own shader does: priced apart
    # a beam pass's time follows the fragments it shades, most of them discarded (approx.cost);
    # where the driver cannot count them, the written ones
    shaded = cost.get("shaded_splat")  # NaN, or None from a stored summary's null, where not counted
    counted = isinstance(shaded, (int, float)) and math.isfinite(shaded)
    beam_fragments = (float(cast(float, shaded)) if counted else cost["fragments_splat"]) if beams else 0.0
    # a differential beam's fragment integrates its kernel over the pixel (splat/beam.frag.glsl):
    # its own weight
    own = splat_mode(params) == DIFFERENTIAL_BEAMS
    maps = 2.0 * float(params.layers) + 1.0  # a front and a back map per layer, and the shadow map
    # beam_width = balanced: per step a pilot draw, the balance pass and the compaction's
    # write again, priced as a second compaction and draw (its fragments are the splat
    # pass's, counted with it: the pilot's shader is the beams'; the llvmpipe fit measures
    # balanced configurations: docs/decisions.md "Frame cost")
    passes = 2.0 if balanced_beams(params) else 1.0
    medium = {name: cost.get(f"medium_reads_{name}", 0.0) for name in MEDIUM_PARTS}
    medium = {name: float(v) if isinstance(v, (int, float)) and math.isfinite(v) else 0.0 for name, v in medium.items()}
    return {
        "volumes": {"calls": 1.0 if medium["volumes"] else 0.0, "medium_reads": medium["volumes"]},
        "layers": {"calls": 1.0, "maps": maps, "texels": maps * float(params.light_res) ** 2,
                   "primitives": cost["primitives_layers"], "fragments": cost["fragments_layers"]},
        "emission": {"calls": 1.0, "primitives": cost["primitives_emission"], "fragments": cost["fragments_emission"],
                     "invocations": launched, "emission_reads": cost["emission_reads"],
                     "medium_reads": medium["emission"]},
        "camera": {"calls": 1.0, "primitives": cost["primitives_camera"], "fragments": cost["fragments_camera"]},
        "trace": {"calls": steps, "invocations": launched * steps, "segments": cost["segments"],
                  "segment_maps": cost["segments"] * 2.0 * float(params.layers),
                  "map_reads": cost["map_reads"], "lookups": cost["lookups"],
                  "lockstep_lookups": cost["lockstep_lookups"], "medium_reads": medium["trace"]},
        "density": {"calls": steps if density else 0.0, "splats": cost["splats"] if density else 0.0,
                    "fragments": cost["fragments_density"]},
        "splat": {"calls": steps * passes, "invocations": launched * steps * passes,
                  "splats": 0.0 if beams else cost["splats"], "fragments": 0.0 if beams else cost["fragments_splat"],
                  "beams": cost["splats"] if beams else 0.0, "beam_fragments": 0.0 if own else beam_fragments,
                  "own_beam_fragments": beam_fragments if own else 0.0, "medium_reads": medium["splat"],
                  # a beam fragment in a heterogeneous medium: ρ, the camera volume and the exp beside its march
                  "medium_fragments": beam_fragments if medium["volumes"] else 0.0},
        "fog": {"calls": 1.0, "fragments": cost["fragments_fog"] * float(params.fog_steps),
                "medium_reads": medium["fog"]},
        "direct": {"calls": 1.0, "fragments": cost["fragments_direct"], "medium_reads": medium["direct"]},
        "other": {"calls": 1.0, "pixels": pixels, "step_pixels": pixels * steps},
    }


@dataclass(frozen=True)
class WeightSet:
    """Per-pass weights of the cost model (pass → feature → seconds per count) and where
    they come from (``provenance``: GL renderer, machine, date, the fit's configurations
    and its error on those left out)."""

    name: str
    unit: str
    weights: dict
    provenance: dict = field(default_factory=dict)

    @property
    def splat_modes(self) -> tuple:
        """The splat modes the set can price: those its fit measured (``provenance``'s
        ``splat_modes``, else its fit's configurations' and the preset's, fixed); a set
        without a fit's record, every mode. A mode the fit never saw has counts (a beam's
        fragments) whose weight it never learnt: its 0 would price them as free."""
        if "splat_modes" in self.provenance:
            return tuple(self.provenance["splat_modes"])
        configs = (self.provenance.get("fit") or {}).get("configs")
        if not isinstance(configs, dict):
            return (*param("splat").choices, DIFFERENTIAL_BEAMS)
        return config_splat_modes(configs)

    @property
    def media(self) -> bool:
        """Whether the set prices a heterogeneous medium's reads (a weight for them in some
        pass: ``bench/cost_model.py --media``). A set fitted on homogeneous scenes alone would
        price them as free."""
        return any("medium_reads" in w for w in self.weights.values())

    def prices(self, params: ApproxParams, cost: dict | None = None) -> bool:
        """Whether the set can price a frame of ``params`` (:attr:`splat_modes`, :func:`splat_mode`)
        and ``cost`` (a heterogeneous medium's reads only with :attr:`media`)."""
        reads = (cost or {}).get("medium_reads", 0)
        heterogeneous = isinstance(reads, (int, float)) and math.isfinite(reads) and reads > 0
        return splat_mode(params) in self.splat_modes and (self.media or not heterogeneous)

    def predict(self, cost: dict, params: ApproxParams) -> dict:
        """pass → predicted time, and ``frame``: their sum."""
        x = features(cost, params)
        out = {name: sum(w * x[name].get(feature, 0.0) for feature, w in self.weights.get(name, {}).items())
               for name in MODEL_PASSES}
        out["frame"] = sum(out.values())
        return out

    def frame(self, cost: dict, params: ApproxParams) -> float:
        return self.predict(cost, params)["frame"]

    def to_dict(self) -> dict:
        return {"name": self.name, "unit": self.unit, "weights": self.weights, "provenance": self.provenance}


def config_splat_modes(configs: dict) -> tuple:
    """The splat modes (:func:`splat_mode`) of a fit's configurations (name → changes from
    the quick preset), fixed always among them: what a set fitted on them prices."""
    modes = {"fixed"}
    for changes in configs.values():
        splat, width = str(changes.get("splat", "fixed")), str(changes.get("beam_width", "fixed"))
        modes.add(DIFFERENTIAL_BEAMS if SPLAT_MODES[splat].beams and width != "fixed" else splat)
    return tuple(sorted(modes))


class WeightSetError(InputError):
    """A weight file that cannot be used: its path, the key, the value and what is allowed."""


#: the top-level keys of a weight file (what ``WeightSet.to_dict`` writes)
WEIGHT_FILE_KEYS = ("name", "unit", "weights", "provenance")
# A weight is 0 or within [MIN_WEIGHT, MAX_WEIGHT] (seconds, or a set's unit, per count): the
# shipped sets span 1.9e-11 to 0.011. With every count below 2^64 and ~45 features, a frame's
# predicted time stays below 1e33, and the ratio of two frames (cost_match.cost_ratio: a
# frame priced at least MIN_WEIGHT, see always_counted) below 1e63: finite in float64, where
# a weight of 1e308 summed to inf and the ratio to NaN.
MIN_WEIGHT = 1e-30
MAX_WEIGHT = 1e12


def always_counted() -> dict:
    """pass → the features every frame counts at least once, whatever its parameters (a
    pass's calls, the light maps and their texels, the photon slots launched, the pixels):
    a weight set prices every frame above 0 only if one of them has a weight > 0."""
    x = features({name: 0.0 for name in _COST_NAMES}, cast("ApproxParams", _Least()))
    return {name: tuple(f for f, v in fs.items() if v > 0) for name, fs in x.items()}


def read_weight_set(path: str) -> WeightSet:
    """A weight set from its JSON file, the whole document checked: an object of
    WEIGHT_FILE_KEYS; ``name`` and ``unit`` non-empty strings; ``weights``: every pass a
    mapping of known features to weights 0 or within [MIN_WEIGHT, MAX_WEIGHT], one > 0 on
    a feature every frame counts (:func:`always_counted`); ``provenance`` an object whose
    ``splat_modes`` (when given) is a non-empty list of splat modes (:func:`splat_mode`)
    and whose ``fit.configs`` (when given) maps names to objects. :class:`WeightSetError`
    (an ``InputError``) naming the file, the key and the value otherwise."""
    special = special_file_kind(path)
    if special:  # opening a FIFO blocks, a device never ends
        raise WeightSetError(f"{path}: {special}, expected a JSON file")
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, ValueError) as exc:
        raise WeightSetError(f"{path}: cannot be read as JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise WeightSetError(f"{path}: holds {type(doc).__name__} {_short(doc)}: expected an object with "
                             f"'weights' (pass -> feature -> weight)")
    unknown = sorted(set(doc) - set(WEIGHT_FILE_KEYS))
    if unknown:
        raise WeightSetError(f"{path}: unknown key {unknown[0]!r}; expected {', '.join(WEIGHT_FILE_KEYS)}")
    weights = doc.get("weights")
    if not isinstance(weights, dict):
        raise WeightSetError(f"{path}: weights = {_short(weights)}: expected an object with 'weights' "
                             f"(pass -> feature -> weight)")
    _check_weights(path, weights)
    for key in ("name", "unit"):
        if key in doc and not (isinstance(doc[key], str) and doc[key].strip()):
            raise WeightSetError(f"{path}: {key} = {_short(doc[key])}: expected a non-empty string, or no {key} "
                                 f"(name: the file's name; unit: s)")
    provenance = doc.get("provenance", {})
    _check_provenance(path, provenance)
    return WeightSet(name=str(doc.get("name") or os.path.splitext(os.path.basename(path))[0]),
                     unit=str(doc.get("unit", "s")), weights=weights, provenance=provenance)


def _check_weights(path: str, weights: dict) -> None:
    known = features({name: 0.0 for name in _COST_NAMES}, cast("ApproxParams", _Probe()))  # _Probe: its fields
    for name, ws in weights.items():
        if name not in known or not isinstance(ws, dict):
            raise WeightSetError(f"{path}: weights.{name} = {_short(ws)}: expected one of {', '.join(MODEL_PASSES)} "
                                 f"with an object (feature -> weight)")
        for feature, w in ws.items():
            if feature not in known[name]:
                raise WeightSetError(f"{path}: weights.{name}.{feature}: unknown feature (expected "
                                     f"{', '.join(known[name])})")
            if isinstance(w, bool) or not isinstance(w, (int, float)) or not (
                    w == 0.0 or MIN_WEIGHT <= w <= MAX_WEIGHT):
                raise WeightSetError(f"{path}: weights.{name}.{feature} = {w!r}: expected 0 or a number within "
                                     f"[{MIN_WEIGHT:g}, {MAX_WEIGHT:g}] (per count, in the set's unit)")
    always = always_counted()
    if not any(w > 0 for name, ws in weights.items() for feature, w in ws.items() if feature in always[name]):
        every = ", ".join(f"{name}.{f}" for name, fs in always.items() for f in fs)
        raise WeightSetError(f"{path}: weights = {_short(weights)}: no weight > 0 on what every frame counts, so "
                             f"every frame would be priced at 0 (and no two compared); give one of {every} a "
                             f"weight > 0")


def _check_provenance(path: str, provenance) -> None:
    if not isinstance(provenance, dict):
        raise WeightSetError(f"{path}: provenance = {_short(provenance)}: expected an object (where the weights "
                             f"come from: machine, date, the fit's configurations, splat_modes)")
    modes = (*param("splat").choices, DIFFERENTIAL_BEAMS)
    if "splat_modes" in provenance:
        given = provenance["splat_modes"]
        if not isinstance(given, list) or not given or any(m not in modes for m in given):
            raise WeightSetError(f"{path}: provenance.splat_modes = {_short(given)}: expected a non-empty list of "
                                 f"the splat modes the fit measured, among {', '.join(modes)}")
    fit = provenance.get("fit")
    if fit is None:
        return
    if not isinstance(fit, dict):
        raise WeightSetError(f"{path}: provenance.fit = {_short(fit)}: expected an object (the fit's record)")
    configs = fit.get("configs")
    if configs is not None and not (isinstance(configs, dict) and all(isinstance(c, dict) for c in configs.values())):
        raise WeightSetError(f"{path}: provenance.fit.configs = {_short(configs)}: expected an object of "
                             f"configuration name -> parameter changes (an object)")


def _short(value) -> str:
    """``value`` as JSON, cut to a line's length."""
    text = json.dumps(value) if isinstance(value, (dict, list, str, int, float, bool, type(None))) else repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def weight_sets(folder: str | None = None) -> dict:
    """name → :class:`WeightSet`: every ``*.json`` of ``folder`` (default WEIGHTS_DIR, the
    shipped sets), each checked (:func:`read_weight_set`); two files of one name are refused."""
    folder = WEIGHTS_DIR if folder is None else folder
    out: dict = {}
    where: dict = {}
    for entry in sorted(os.listdir(folder)) if os.path.isdir(folder) else []:
        if entry.endswith(".json"):
            path = os.path.join(folder, entry)
            ws = read_weight_set(path)
            if ws.name in out:
                raise WeightSetError(f"{path}: name = {ws.name!r}: {where[ws.name]} names its set so too; give each "
                                     f"weight set its own name")
            out[ws.name], where[ws.name] = ws, path
    return out


def predicted_frames(cost: dict, params: ApproxParams, sets: dict | None = None) -> dict:
    """name → predicted frame time of (cost, params) under each weight set that prices it
    (:meth:`WeightSet.prices`: its splat mode, and a heterogeneous medium's reads; default:
    the shipped ones; each in its set's unit)."""
    sets = weight_sets() if sets is None else sets
    return {name: ws.frame(cost, params) for name, ws in sets.items() if ws.prices(params, cost)}


_COST_NAMES = ("map_reads", "emission_reads", "splats", "segments", "lookups", "lockstep_lookups",
               *(f"fragments_{n}" for n in TIMED_PASSES), *(f"primitives_{n}" for n in TIMED_PASSES))


class _Probe:
    """Parameters for listing the features (any values)."""

    photon_res = steps = width = height = fog_steps = layers = light_res = 1
    fresnel_splits = 0
    splat = "density"
    beam_width = "fixed"


class _Least(_Probe):
    """The least a frame counts: every size at its minimum, no density pre-pass."""

    splat = "fixed"
