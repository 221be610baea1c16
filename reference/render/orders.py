"""The third stream of a reference rendered with K > 1 scattering orders: what the
orders beyond the paper's single-scattering model add (docs/concepts/model-term.md), and the
rule that says whether K orders are enough.

One batch is one render of the light tracer in mode ``orders`` (``integrators``): every
path counted by its last vertex (caustic, fog: a medium vertex; direct: a diffuse
surface) and its number n of real scattering events in the medium. The paper's model
is n = 1 for caustic and fog and n = 0 for direct; the **model term** of a component is
the sum of its other orders up to K, ``<component>_ms`` (``scenes.formats.MODEL_LAYERS``).
The stream also keeps each of those orders' images, ``<component>@<n>``, for the rule;
the tracer counts only them (``beyond_model``: the other streams render the model's).

**Convergence rule**: order n + 1 changes the total image by o, whose
relative MSE against the total R_ms is Σ o² / Σ R_ms² over the non-glass pixels,
debiased by o's own variance (Σ (o² − var o)). K orders are enough for a component when
order K's change is at most the noise floor of R_ms (its variance over Σ R_ms²); the
smallest order from which every later one rendered is below it is reported as the
component's K.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .batches import BatchStats

# mode "orders" counts a path by its last vertex: a medium vertex after ≥ 1 specular
# interaction (caustic) or none (fog), or a diffuse surface reached without one (direct)
ORDER_COMPONENTS = ("caustic", "fog", "direct")
SINGLE_ORDER = {"caustic": 1, "fog": 1, "direct": 0}  # the paper's model: scattering events on the path
MODEL_FLOORS = tuple(f"{c}_ms" for c in ORDER_COMPONENTS)  # the noise floors (and targets) of the model term
GROUPED = (*MODEL_FLOORS, "combined_ms")  # the orders stream's images kept in batch groups (the model term's SEs)


def excess_orders(component: str, max_scatter: int) -> range:
    """The orders of ``component`` beyond the paper's model, up to ``max_scatter``."""
    return range(SINGLE_ORDER[component] + 1, max_scatter + 1)


def order_name(component: str, order: int) -> str:
    return f"{component}@{order}"


def stream_images(max_scatter: int) -> tuple:
    """Image names of the orders stream: the model terms, their sum, then every order's image."""
    per_order = tuple(order_name(c, n) for c in ORDER_COMPONENTS for n in excess_orders(c, max_scatter))
    return (*MODEL_FLOORS, "combined_ms", *per_order)


def batch_images(stack: np.ndarray, max_scatter: int) -> dict:
    """The stream's images of one batch from the tracer's order images
    (``integrators.VolumetricLightTracer.order_images``: [component, order, H, W, 3])."""
    out = {}
    for i, c in enumerate(ORDER_COMPONENTS):
        out[f"{c}_ms"] = stack[i, list(excess_orders(c, max_scatter))].sum(axis=0)
        for n in excess_orders(c, max_scatter):
            out[order_name(c, n)] = stack[i, n]
    out["combined_ms"] = sum(out[name] for name in MODEL_FLOORS)  # kept for its variance (pixels covary)
    return out


def stream_max_scatter(names: Iterable[str]) -> int:
    """K of an orders stream from its image names (the highest order it holds)."""
    return max(int(name.split("@")[1]) for name in names if "@" in name)


def _totals(single: dict, orders) -> dict:
    """R_ms per colour layer: the single-scattering mean (``single``: component →
    image) plus the model term (``orders``: reference.batches.BatchStats)."""
    out = {c: single[c] + orders.mean(f"{c}_ms") for c in ORDER_COMPONENTS}
    return out


def model_floors(single: dict, orders: BatchStats, keep: np.ndarray) -> dict:
    """The model term's noise floor per component (``<component>_ms``): the variance of
    the term over Σ R_ms² on the pixels ``keep`` (None without energy). The term's
    noise is what the multiple-scattering stream adds to R_ms's floor."""
    totals, out = _totals(single, orders), {}
    for c in ORDER_COMPONENTS:
        energy = float(np.sum(totals[c][keep] ** 2))
        out[f"{c}_ms"] = float(np.sum(orders.var(f"{c}_ms")[keep]) / energy) if energy > 0 else None
    return out


def convergence(single: dict, single_var: dict, orders: BatchStats, keep: np.ndarray) -> dict:
    """Per component: ``order_relmse`` (each order's debiased Σ (o² − var o) / Σ R_ms²,
    from the first beyond the paper's model), ``floor`` (R_ms's noise floor: the
    single-scattering variance plus the term's, over Σ R_ms²), ``energy_share`` (each
    order's Σ o / Σ R_ms) and ``orders_needed`` (the smallest K for which every later
    rendered order is at most the floor; None when even the last is above it: not
    converged)."""
    max_scatter = stream_max_scatter(orders.names)
    out: dict
    totals, out = _totals(single, orders), {}
    for c in ORDER_COMPONENTS:
        energy = float(np.sum(totals[c][keep] ** 2))
        if energy <= 0:
            out[c] = None
            continue
        floor = float(np.sum((single_var[c] + orders.var(f"{c}_ms"))[keep]) / energy)
        relmse, share = [], []
        for n in excess_orders(c, max_scatter):
            o, v = orders.mean(order_name(c, n))[keep], orders.var(order_name(c, n))[keep]
            relmse.append(float(np.sum(o * o - v) / energy))
            share.append(float(np.sum(o) / np.sum(totals[c][keep])))
        needed = SINGLE_ORDER[c]
        for n, r in zip(excess_orders(c, max_scatter), relmse):
            if r > floor:
                needed = n  # order n still changes the total by more than the noise
        out[c] = {"order_relmse": relmse, "energy_share": share, "floor": floor,
                  "orders_needed": None if needed == max_scatter else needed}
    return out
