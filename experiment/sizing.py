"""The reference's budget and size: the one place that turns an image size into
reference settings.

The main job's budget (``make report``, ``volcaustics report``, ``measure``, the gate's
and a sweep's default): 2^21 photons and 32 camera samples per pixel over at least 8
batches per stream (a batch: 2^18 photons, 4 samples per pixel), then more until the
noise floors meet the targets — caustic 0.5%, fog and direct 0.2%, the model term's
0.5% — or 2 minutes per scene pass; 8 scattering orders for the model term. The
minimum of 8 is the light streams' batch groups (``reference.render.batches.
LIGHT_GROUPS``), one batch each: the jackknife SEs over them stay calibrated there as
at 16 (docs/decisions.md "References held to what their noise needs").
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, cast

from volcaustics.infra.errors import InputError
from volcaustics.reference.settings import ReferenceSettings, SettingsError

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.scenes.model import Scene

REPORT_TARGET = "caustic=0.005,fog=0.002,direct=0.002,caustic_ms=0.005,fog_ms=0.005,direct_ms=0.005"
# K = 8 scattering orders: the convergence rule needs 2–4 on the built-ins (order 5 changes
# R_ms by a relative MSE of ~5e-6), and orders 5–8 cost little (docs/decisions.md
# "Multiple scattering and the model term")
REPORT_MAX_SCATTER = 8
REPORT_REFERENCE = ReferenceSettings(photons=1 << 21, spp=32, batches=8, target_noise=REPORT_TARGET,  # type: ignore[arg-type]
                                     max_seconds=120.0, max_scatter=REPORT_MAX_SCATTER)
# what a sweep spec's or the budgets' [reference] table may change
REFERENCE_KEYS = ("photons", "spp", "batches", "target_noise", "max_photons", "max_seconds", "max_scatter")


def reference_settings(overrides: dict) -> ReferenceSettings:
    """The report's budget with ``overrides`` (REFERENCE_KEYS; a target_noise of
    "none" renders exactly ``batches``); InputError for a bad one."""
    changes = dict(overrides)
    unknown = [key for key in changes if key not in REFERENCE_KEYS]
    if unknown:
        raise InputError(f"reference.{unknown[0]}: unknown; expected {', '.join(REFERENCE_KEYS)}")
    if isinstance(changes.get("target_noise"), str) and changes["target_noise"].strip().lower() == "none":
        changes["target_noise"] = None  # render exactly `batches` batches
    try:
        return dataclasses.replace(REPORT_REFERENCE, **changes) if changes else REPORT_REFERENCE
    except (SettingsError, TypeError) as exc:
        raise InputError(f"reference: {exc}") from None


def sized(settings: ReferenceSettings, scene: Scene, params: ApproxParams) -> ReferenceSettings:
    """``settings`` at the image size of the approximation's ``params`` on ``scene``
    (width/height unset: the scene camera's): one render, one cache key."""
    p = params.resolved(scene)
    return at_size(settings, cast(int, p.width), cast(int, p.height))  # resolved: the scene camera's size


def at_size(settings: ReferenceSettings, width: int, height: int) -> ReferenceSettings:
    """``settings`` for images of ``width`` × ``height`` pixels (``compare``: the size of
    the images it is given)."""
    return dataclasses.replace(settings, width=width, height=height)
