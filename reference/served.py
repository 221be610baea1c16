"""A cached reference judged against the request it is served to.

A cache entry is keyed by what one batch is, not by how long a request asked it to render
(``settings.BUDGET_FIELDS``: photons, spp, batches, target_noise and the caps), so an entry
rendered for one request can serve another: one with a target it already meets, or (the
policies that take an entry as it is) any. Its manifest records the request it was rendered
for; a run says how the entry stands against its own (:func:`judged`), never repeats the
other request's verdict ("time cap, target 0.00%" after a run with a target of 1e-300).
"""

from __future__ import annotations

import json

from .settings import BUDGET_FIELDS, NOISE_COMPONENTS, ReferenceSettings

#: the camera stream's components, which no photon cap stops (the light tracer's, caustic and
#: the model term's, stop at it)
CAMERA_COMPONENTS = ("fog", "direct")
#: stopped_by of an entry served as it is, short of the request's batches or targets
#: (the policies ``cached`` and ``missing``: ``reports.measuring.runner``)
AS_CACHED = "served as cached"


def budget(settings: dict) -> dict:
    """The budget fields (``settings.BUDGET_FIELDS``) of a settings dict
    (``ReferenceSettings.to_dict``, or a manifest's ``settings``), as JSON has them."""
    return json.loads(json.dumps({name: settings.get(name) for name in BUDGET_FIELDS}))


def judged(manifest: dict, request: ReferenceSettings | None) -> dict:
    """How the cache entry of ``manifest`` stands against ``request`` (resolved settings;
    None: the request the entry was rendered for).

    Returns
    -------
    dict with ``request``: the request's budget (:func:`budget`); ``rendered_for``: None
    when the entry was rendered for this budget, else the budget it was rendered for;
    ``short_of_target``: component → {"noise_floor", "target"} for each of the request's
    targets the entry's floor is above; ``stopped_by``: the entry's own ("batches",
    "target", "photon cap", "time cap") where it was rendered for this budget, else judged
    against it: "batches" (no target), "target" (every target met), "photon cap" (only
    light-stream components short, the request's photon cap reached by the entry's
    photons) or AS_CACHED (fewer batches than asked, or a target not met that no cap of
    the request stopped).

    Example
    -------
    >>> judged(result.manifest, settings)["stopped_by"]   # doctest: +SKIP
    'target'
    """
    own = budget(manifest.get("settings") or {})
    asked = own if request is None else budget(request.to_dict())
    targets = (own.get("target_noise") or {}) if request is None else request.targets()
    floors = manifest.get("noise_floor") or {}
    short = {name: {"noise_floor": floors[name], "target": target} for name, target in targets.items()
             if isinstance(floors.get(name), (int, float)) and floors[name] > target}
    if request is None or own == asked:
        stopped_by = manifest.get("stopped_by")
    else:
        stopped_by = _against(manifest, request, short)
    return {"request": asked, "rendered_for": None if own == asked else own, "short_of_target": short,
            "stopped_by": stopped_by}


def _against(manifest: dict, request: ReferenceSettings, short: dict) -> str:
    counts = [manifest.get("batches"), manifest.get("camera_batches")]
    if request.max_scatter > 1:
        counts.append(manifest.get("orders_batches"))
    if any(not isinstance(n, int) or n < request.batches for n in counts):
        return AS_CACHED
    if not request.targets():
        return "batches"
    if not short:
        return "target"
    photons = manifest.get("photons")
    capped = isinstance(photons, int) and request.photon_cap_reached(photons)
    return "photon cap" if capped and not any(name in CAMERA_COMPONENTS for name in short) else AS_CACHED


def meets(manifest: dict, request: ReferenceSettings) -> bool:
    """Whether the cache entry of ``manifest`` meets ``request`` as it is: its batches, and
    every target met or its photon cap reached (a ``continue`` run serves it, else
    continues it)."""
    floors = manifest.get("noise_floor") or {}
    short = {name: target for name, target in request.targets().items()
             if isinstance(floors.get(name), (int, float)) and floors[name] > target}
    return _against(manifest, request, short) != AS_CACHED


def describe_budget(budget: dict) -> str:
    """A request's budget in a line: its target (or its batches) and its caps."""
    target = budget.get("target_noise")
    if not target:
        return f"{budget.get('batches')} batches, no noise target"
    if set(target) == set(NOISE_COMPONENTS) and len(set(target.values())) == 1:
        floors = f"{100 * next(iter(target.values())):.3g}% for every component"
    else:
        floors = ", ".join(f"{name} {100 * value:.3g}%" for name, value in target.items())
    return f"target {floors}, max_photons {budget.get('max_photons'):,}, max_seconds {budget.get('max_seconds'):g}"
