"""Equal cost (docs/approx.md: the photon_res at which a configuration's
frame cost (``approx.cost``: map and emission reads, splats and density reads,
hardware-independent) is at most a target on a scene — the best search's step 1
(``reports.sweep.best``) and ``photon_res`` = auto (the preset ``best``: the paper
configuration's frame cost at the same image size, on the scene at hand).

photon_res ← photon_res·√(target / cost), re-rendered until it stays, then lowered 1%
at a time until within; remembered in ``FOLDER/matched.json`` under a key of the scene,
the parameters, the target and the code version.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os

from volcaustics.approx import Renderer
from volcaustics.approx.cost import frame_cost
from volcaustics.approx.params import AUTO_PHOTON_RES, preset
from volcaustics.infra.storage import atomic_path, cache_dir
from volcaustics.reports.core.versions import code_version
from volcaustics.scenes import resolve_scene

MATCHED = "matched.json"  # the cost-matched photon_res per scene and configuration (a memo: recomputed if lost)
MIN_PHOTON_RES = 16


class CostMatcher:
    """The photon_res at which a configuration's frame costs at most a target on a scene
    (module docstring), remembered in ``FOLDER/matched.json``."""

    def __init__(self, folder: str):
        self.path = os.path.join(folder, MATCHED)
        self.memo = {}
        self.renderers = {}
        try:
            with open(self.path, encoding="utf-8") as fh:
                memo = json.load(fh)
            self.memo = memo if isinstance(memo, dict) else {}
        except (OSError, ValueError):
            pass  # none yet, or damaged: recomputed

    def cost(self, scene_name: str, params) -> int:
        """The frame cost (``approx.cost``: total) of one frame of ``params``."""
        scene = resolve_scene(scene_name)
        if scene_name not in self.renderers:
            self.renderers[scene_name] = Renderer(scene)
        frame = self.renderers[scene_name].render(scene, params, keep_records=True)
        return frame_cost(frame.records, params.resolved(scene))["total"]

    def match(self, scene_name: str, params, target: float):
        """``params`` with the largest photon_res found whose cost is ≤ ``target``."""
        doc = [resolve_scene(scene_name).scene_hash(), params.to_dict(), float(target), code_version()]
        key = hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()[:20]
        if isinstance(self.memo.get(key), int):
            return dataclasses.replace(params, photon_res=self.memo[key])
        res = params.photon_res
        cost = self.cost(scene_name, params)
        for _ in range(6):
            new = max(MIN_PHOTON_RES, min(8192, int(res * math.sqrt(target / max(cost, 1)))))
            if new == res:
                break
            res, cost = new, self.cost(scene_name, dataclasses.replace(params, photon_res=new))
        while cost > target and res > MIN_PHOTON_RES:
            res = max(MIN_PHOTON_RES, res - max(1, res // 100))
            cost = self.cost(scene_name, dataclasses.replace(params, photon_res=res))
        self.memo[key] = res
        return dataclasses.replace(params, photon_res=res)

    def save(self) -> None:
        with atomic_path(self.path) as tmp, open(tmp, "w", encoding="utf-8") as fh:
            json.dump(self.memo, fh)

    def release(self) -> None:
        for renderer in self.renderers.values():
            renderer.release()
        self.renderers = {}




def with_auto_photon_res(scene_arg: str, params, preset_name: str | None, given: bool):
    """``params`` with photon_res matched to the paper configuration's frame cost at the
    same image size on ``scene_arg`` when the preset asks for it (AUTO_PHOTON_RES) and no
    photon_res was ``given``; else ``params`` unchanged."""
    if preset_name not in AUTO_PHOTON_RES or given:
        return params
    scene = resolve_scene(scene_arg)
    paper = preset(AUTO_PHOTON_RES[preset_name], width=params.width, height=params.height)
    folder = cache_dir("cost_match")
    matcher = CostMatcher(folder)
    try:
        matched = matcher.match(scene_arg, params, matcher.cost(scene_arg, paper.resolved(scene)))
        matcher.save()
    finally:
        matcher.release()
    return matched
