"""Equal cost (docs/concepts/equal-cost.md): the photon_res at which a configuration's
frame costs at most a target on a scene — the best search's step 1
(``reports.studies.best.best_search``) and ``photon_res`` = auto (the preset ``best``: the paper
configuration's frame at the same image size, on the scene at hand), after layers = auto
(:func:`auto_layers`: the presets' layers from the scene's depth complexity).

A frame's cost is its predicted time under every shipped weight set of the cost model
(``approx.cost_model``: the counted work of every pass, fragments included, weighted by
fitted per-count times); a configuration is within the target when it is at most 1.0×
under each. photon_res ← photon_res·√(1 / ratio), re-rendered until it stays, then
lowered 1% at a time until within; remembered in ``FOLDER/matched.json`` under a key of
the scene, the parameters, the target (its costs, or the paper configuration's parameters:
:meth:`CostMatcher.match_to`), the weight sets and the code version. An entry is sealed
(``infra.storage.document_sha256``): one edited, damaged or out of range is recomputed,
and a cache that cannot be written leaves the match computed, not stored. The seal proves
integrity, not provenance: anyone who can write the cache can re-seal an entry with another
value (a plain SHA-256, no secret; a key kept in the same cache would prove no more), and it
is used. A code change makes every entry stale (the key's code version); ``measure --preset
best`` prices and times the match again (:func:`equal_cost_check`, ``at_paper_cost`` in its
summary); removing ``matched.json`` or giving ``--photon-res`` sets the memo aside.
:func:`measured_time_ratio` checks the match in time (alternating frames).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import statistics
from functools import lru_cache
from typing import TYPE_CHECKING

from volcaustics import approx, scenes
from volcaustics.approx import Renderer, cost_model
from volcaustics.approx.cost import frame_cost
from volcaustics.approx.cost_model import WeightSetError, predicted_frames, weight_sets
from volcaustics.approx.layers import levels_needed
from volcaustics.approx.params import AUTO_LAYERS, AUTO_PHOTON_RES, preset
from volcaustics.infra.sources import source_code, source_hash
from volcaustics.infra.storage import atomic_path, cache_path, document_sha256, note_not_cached, read_json_object
from volcaustics.scenes import resolve_scene

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.scenes.model import Scene


@lru_cache(maxsize=None)
def code_version() -> str:
    """The code a frame's cost depends on, part of every memo key: the approximation's
    and the scenes' sources and this module's (``infra.sources``), wherever the packages
    are installed."""
    own = hashlib.sha256(source_code(os.path.abspath(__file__))).hexdigest()[:16]
    return source_hash({"approx": approx.__path__[0], "scenes": scenes.__path__[0]}) + own


MATCHED = "matched.json"  # the cost-matched photon_res per scene and configuration (a memo: recomputed if lost)
MIN_PHOTON_RES = 16
MAX_PHOTON_RES = 8192  # the search's ceiling (a memo entry beyond it is damaged)


class CostMatcher:
    """The photon_res at which a configuration's frame costs at most a target on a scene
    (module docstring), remembered in ``FOLDER/matched.json``."""

    def __init__(self, folder: str):
        self.path = os.path.join(folder, MATCHED)
        self.memo = {}
        self.renderers: dict = {}
        self.scenes: dict = {}  # scene argument → its Scene, loaded once (a load checks every animation frame)
        self.sets = weight_sets()
        if not self.sets:
            raise WeightSetError(f"{cost_model.WEIGHTS_DIR}: holds no weight set (*.json): the cost model cannot "
                                 f"price a frame; restore the shipped sets or fit one (bench/cost_model.py --write)")
        try:
            self.memo = read_json_object(self.path)
        except (OSError, ValueError):
            pass  # none yet, or damaged (a special file is never opened): recomputed

    def cost(self, scene_name: str, params: ApproxParams) -> dict:
        """One frame of ``params``: its predicted time under each weight set (name → value,
        ``approx.cost_model``)."""
        scene = self.scene(scene_name)
        if scene_name not in self.renderers:
            self.renderers[scene_name] = Renderer(scene)
        frame = self.renderers[scene_name].render(scene, params, keep_records=True)
        p = params.resolved(scene)
        return predicted_frames(frame_cost(frame.records, p, frame.work), p, self.sets)

    def scene(self, scene_name: str) -> Scene:
        """The scene ``scene_name`` names (``scenes.resolve_scene``), loaded once per matcher: a
        search renders a dozen frames, and loading refocus (its animation's frames checked)
        took 0.24 s, 3.3 of a 32² match's 5.9 s."""
        if scene_name not in self.scenes:
            self.scenes[scene_name] = resolve_scene(scene_name)
        return self.scenes[scene_name]

    def match(self, scene_name: str, params: ApproxParams, target: dict) -> ApproxParams:
        """``params`` with the largest photon_res found whose cost is ≤ ``target`` (the
        paper configuration's :meth:`cost`) under every weight set."""
        key = self._key(scene_name, params, {k: float(v) for k, v in target.items()})
        return self._remembered(key, params) or self._search(key, scene_name, params, target)

    def match_to(self, scene_name: str, params: ApproxParams, paper: ApproxParams) -> ApproxParams:
        """:meth:`match` against the frame of ``paper`` (resolved parameters), which is
        rendered only when the memo does not have the answer."""
        key = self._key(scene_name, params, {"paper": paper.to_dict()})
        return self._remembered(key, params) or self._search(key, scene_name, params, self.cost(scene_name, paper))

    def _key(self, scene_name: str, params, target) -> str:
        doc = [self.scene(scene_name).scene_hash(), params.to_dict(), target,
               {name: ws.weights for name, ws in self.sets.items()}, code_version()]
        return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()[:20]

    def _remembered(self, key: str, params):
        """``params`` with the memo's photon_res for ``key``; None when there is none or
        its entry is not sealed, not an integer in range (recomputed)."""
        entry = self.memo.get(key)
        if not isinstance(entry, dict):
            return None
        res = entry.get("photon_res")
        if isinstance(res, bool) or not isinstance(res, int) or not MIN_PHOTON_RES <= res <= MAX_PHOTON_RES:
            return None
        if entry.get("sha256") != document_sha256({**entry, "key": key}, "sha256"):
            return None
        return dataclasses.replace(params, photon_res=res)

    def _search(self, key: str, scene_name: str, params, target: dict):
        res = params.photon_res
        cost = cost_ratio(self.cost(scene_name, params), target)
        for _ in range(6):
            new = max(MIN_PHOTON_RES, min(MAX_PHOTON_RES, int(res * math.sqrt(1.0 / max(cost, 1e-9)))))
            if new == res:
                break
            res, cost = new, cost_ratio(self.cost(scene_name, dataclasses.replace(params, photon_res=new)), target)
        while cost > 1.0 and res > MIN_PHOTON_RES:
            res = max(MIN_PHOTON_RES, res - max(1, res // 100))
            cost = cost_ratio(self.cost(scene_name, dataclasses.replace(params, photon_res=res)), target)
        entry = {"photon_res": res, "cost_ratio": float(cost)}
        self.memo[key] = {**entry, "sha256": document_sha256({**entry, "key": key}, "sha256")}
        return dataclasses.replace(params, photon_res=res)

    def save(self) -> None:
        """Store the memo; a cache that cannot be written is said once and the run goes on
        (the matches are computed again next time)."""
        try:
            os.makedirs(os.path.dirname(self.path), exist_ok=True)
            with atomic_path(self.path) as tmp, open(tmp, "w", encoding="utf-8") as fh:
                json.dump(self.memo, fh)
        except OSError as exc:
            note_not_cached(exc, "cost-matched photon_res values")

    def release(self) -> None:
        for renderer in self.renderers.values():
            renderer.release()
        self.renderers = {}




def with_auto_values(scene_arg: str, params: ApproxParams, preset_name: str | None, given: bool, *,
                     layers_given: bool = False, scene: Scene | None = None) -> ApproxParams:
    """``params`` with the values the preset takes from the scene at hand: layers from
    the scene's depth complexity (:func:`auto_layers`) when the preset asks for it
    (AUTO_LAYERS) and no layers were given (``layers_given``); then photon_res matched
    to the paper configuration's frame cost at the same image size on ``scene_arg`` when
    the preset asks for it (AUTO_PHOTON_RES) and no photon_res was ``given``: the extra
    layers' maps and lookups are paid for with photons. Else ``params`` unchanged.
    ``scene``: ``scene_arg`` resolved already (None: resolved here when needed)."""
    if preset_name in AUTO_LAYERS and not layers_given:
        layers = auto_layers(scene_arg, params.light_res, scene=scene)
        params = params if layers == params.layers else dataclasses.replace(params, layers=layers)
    if preset_name not in AUTO_PHOTON_RES or given:
        return params
    scene = scene or resolve_scene(scene_arg)
    paper = preset(AUTO_PHOTON_RES[preset_name], width=params.width, height=params.height)
    matcher = CostMatcher(cache_path("cost_match"))  # read as it is; written only if it can be
    matcher.scenes[scene_arg] = scene
    try:
        matched = matcher.match_to(scene_arg, params, paper.resolved(scene))
        matcher.save()
    finally:
        matcher.release()
    return matched


@lru_cache(maxsize=64)
def _levels(scene_hash: str, scene_arg: str, light_res: int) -> tuple:
    """The texels per peeled level of ``scene_arg`` (``Renderer.depth_levels``), once per
    process for a scene's content (``scene_hash``: an edited file is probed again)."""
    scene = resolve_scene(scene_arg)
    renderer = Renderer(scene)
    try:
        return tuple(renderer.depth_levels(scene, light_res))
    finally:
        renderer.release()


def auto_layers(scene_arg: str, light_res: int, *, scene: Scene | None = None) -> int:
    """layers = auto on ``scene_arg`` (``scene``: resolved already, or None): the peeled
    light-map levels that hold a share of the light's texels that is not negligible
    (``approx.layers.levels_needed``), at the frame's ``light_res``, up to 8; 1 for a
    single convex object."""
    return levels_needed(list(_levels((scene or resolve_scene(scene_arg)).scene_hash(), scene_arg, light_res)))


def cost_ratio(cost: dict, target: dict) -> float:
    """The largest ratio of a predicted cost (:meth:`CostMatcher.cost`) to a target's
    over the weight sets that price both (a set's fit that never saw a splat mode does
    not price it: ``WeightSet.prices``): within the target when ≤ 1. WeightSetError (bad
    input) when no set prices both."""
    shared = [name for name in target if name in cost]
    if not shared:
        raise WeightSetError(f"no weight set prices both frames (sets {sorted(cost)} against {sorted(target)}): "
                         f"fit the cost model with the configuration's splat mode (bench/cost_model.py)")
    return max(cost[name] / target[name] for name in shared)


def measured_time_ratio(scene_arg: str, params: ApproxParams, paper: ApproxParams, *, frames: int = 5) -> dict:
    """Measured frame time of ``params`` against ``paper`` on ``scene_arg``: one renderer,
    a warm-up frame of each, then ``frames`` frames of each alternating (no records);
    medians (s) and their ratio."""
    scene = resolve_scene(scene_arg)
    renderer = Renderer(scene)
    try:
        for p in (paper, params):
            renderer.render(scene, p, keep_records=False)
        times: dict = {"paper": [], "config": []}
        for _ in range(frames):
            for name, p in (("paper", paper), ("config", params)):
                times[name].append(renderer.render(scene, p, keep_records=False).timings["frame_wall"])
    finally:
        renderer.release()
    paper_s, config_s = statistics.median(times["paper"]), statistics.median(times["config"])
    return {"paper_s": paper_s, "config_s": config_s, "ratio": config_s / paper_s, "frames": frames,
            "method": "median of alternating frames, one renderer"}


def equal_cost_check(scene_arg: str, params: ApproxParams, preset_name: str) -> dict | None:
    """For a preset matched to the paper configuration's cost (AUTO_PHOTON_RES): its
    predicted cost ratio under every weight set that prices it and its measured frame time ratio
    (:func:`measured_time_ratio`), and whether it is at the paper's cost (≤ 1.0× under
    every set, ≤ TIME_SLACK× in time); None for another preset."""
    if preset_name not in AUTO_PHOTON_RES:
        return None
    scene = resolve_scene(scene_arg)
    paper = preset(AUTO_PHOTON_RES[preset_name], width=params.width, height=params.height)
    matcher = CostMatcher(cache_path("cost_match"))
    matcher.scenes[scene_arg] = scene
    try:
        own, target = matcher.cost(scene_arg, params), matcher.cost(scene_arg, paper.resolved(scene))
    finally:
        matcher.release()
    predicted = {name: own[name] / target[name] for name in target if name in own}
    time = measured_time_ratio(scene_arg, params.resolved(scene), paper.resolved(scene))
    return {"predicted_ratio": predicted, "measured_time": time,
            "at_paper_cost": bool(max(predicted.values()) <= 1.0 and time["ratio"] <= TIME_SLACK)}


TIME_SLACK = 1.05  # "at the paper's cost" in measured time: ≤ 1.05× its frame (docs/concepts/equal-cost.md)
