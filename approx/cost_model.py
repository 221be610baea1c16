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

from .cost import TIMED_PASSES
from .params import differential_beams, param, photon_slots

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
    ``maps``, ``texels``: the light maps drawn and their texels (cleared and packed)."""
    launched = float(photon_slots(params))
    steps = float(params.steps)
    pixels = float(cast(int, params.width) * cast(int, params.height))  # resolved: both set
    density = params.splat == "density"
    beams = params.splat == "beams"  # a beam's fragment costs what its own shader does: priced apart
    # a beam pass's time follows the fragments it shades, most of them discarded (approx.cost);
    # where the driver cannot count them, the written ones
    shaded = cost.get("shaded_splat")  # NaN, or None from a stored summary's null, where not counted
    counted = isinstance(shaded, (int, float)) and math.isfinite(shaded)
    beam_fragments = (float(cast(float, shaded)) if counted else cost["fragments_splat"]) if beams else 0.0
    # a differential beam's fragment integrates its kernel over the pixel (splat/beam.frag.glsl):
    # its own weight
    own = splat_mode(params) == DIFFERENTIAL_BEAMS
    maps = 2.0 * float(params.layers) + 1.0  # a front and a back map per layer, and the shadow map
    return {
        "layers": {"calls": 1.0, "maps": maps, "texels": maps * float(params.light_res) ** 2,
                   "primitives": cost["primitives_layers"], "fragments": cost["fragments_layers"]},
        "emission": {"calls": 1.0, "primitives": cost["primitives_emission"], "fragments": cost["fragments_emission"],
                     "invocations": launched, "emission_reads": cost["emission_reads"]},
        "camera": {"calls": 1.0, "primitives": cost["primitives_camera"], "fragments": cost["fragments_camera"]},
        "trace": {"calls": steps, "invocations": launched * steps, "segments": cost["segments"],
                  "segment_maps": cost["segments"] * 2.0 * float(params.layers),
                  "map_reads": cost["map_reads"], "lookups": cost["lookups"],
                  "lockstep_lookups": cost["lockstep_lookups"]},
        "density": {"calls": steps if density else 0.0, "splats": cost["splats"] if density else 0.0,
                    "fragments": cost["fragments_density"]},
        "splat": {"calls": steps, "invocations": launched * steps,
                  "splats": 0.0 if beams else cost["splats"], "fragments": 0.0 if beams else cost["fragments_splat"],
                  "beams": cost["splats"] if beams else 0.0, "beam_fragments": 0.0 if own else beam_fragments,
                  "own_beam_fragments": beam_fragments if own else 0.0},
        "fog": {"calls": 1.0, "fragments": cost["fragments_fog"] * float(params.fog_steps)},
        "direct": {"calls": 1.0, "fragments": cost["fragments_direct"]},
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
        configs = self.provenance.get("fit", {}).get("configs")
        if not isinstance(configs, dict):
            return (*param("splat").choices, DIFFERENTIAL_BEAMS)
        return config_splat_modes(configs)

    def prices(self, params: ApproxParams) -> bool:
        """Whether the set can price a frame of ``params`` (:attr:`splat_modes`, :func:`splat_mode`)."""
        return splat_mode(params) in self.splat_modes

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
        modes.add(DIFFERENTIAL_BEAMS if splat == "beams" and width == "differential" else splat)
    return tuple(sorted(modes))


class WeightSetError(ValueError):
    """A weight file that cannot be used: its path and what is wrong."""


def read_weight_set(path: str) -> WeightSet:
    """A weight set from its JSON file, checked (every pass a mapping of known features to
    finite weights ≥ 0)."""
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, ValueError) as exc:
        raise WeightSetError(f"{path}: cannot be read as JSON ({exc})") from None
    known = features({name: 0.0 for name in _COST_NAMES}, cast("ApproxParams", _Probe()))  # _Probe: its fields
    weights = doc.get("weights") if isinstance(doc, dict) else None
    if not isinstance(weights, dict):
        raise WeightSetError(f"{path}: expected an object with 'weights' (pass -> feature -> weight)")
    for name, ws in weights.items():
        if name not in known or not isinstance(ws, dict):
            raise WeightSetError(f"{path}: weights.{name}: expected one of {', '.join(MODEL_PASSES)} with an object")
        for feature, w in ws.items():
            if feature not in known[name]:
                raise WeightSetError(f"{path}: weights.{name}.{feature}: unknown feature (expected "
                                     f"{', '.join(known[name])})")
            if isinstance(w, bool) or not isinstance(w, (int, float)) or not 0.0 <= w < float("inf"):
                raise WeightSetError(f"{path}: weights.{name}.{feature} = {w!r}: expected a finite number >= 0")
    return WeightSet(name=str(doc.get("name") or os.path.splitext(os.path.basename(path))[0]),
                     unit=str(doc.get("unit", "s")), weights=weights, provenance=doc.get("provenance", {}))


def weight_sets(folder: str = WEIGHTS_DIR) -> dict:
    """name → :class:`WeightSet`: every ``*.json`` of ``folder`` (the shipped sets)."""
    out = {}
    for entry in sorted(os.listdir(folder)) if os.path.isdir(folder) else []:
        if entry.endswith(".json"):
            ws = read_weight_set(os.path.join(folder, entry))
            out[ws.name] = ws
    return out


def predicted_frames(cost: dict, params: ApproxParams, sets: dict | None = None) -> dict:
    """name → predicted frame time of (cost, params) under each weight set that prices it
    (:meth:`WeightSet.prices`; default: the shipped ones; each in its set's unit)."""
    sets = weight_sets() if sets is None else sets
    return {name: ws.frame(cost, params) for name, ws in sets.items() if ws.prices(params)}


_COST_NAMES = ("map_reads", "emission_reads", "splats", "segments", "lookups", "lockstep_lookups",
               *(f"fragments_{n}" for n in TIMED_PASSES), *(f"primitives_{n}" for n in TIMED_PASSES))


class _Probe:
    """Parameters for listing the features (any values)."""

    photon_res = steps = width = height = fog_steps = layers = light_res = 1
    fresnel_splits = 0
    splat = "density"
    beam_width = "fixed"
