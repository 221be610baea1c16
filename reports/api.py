"""The harness from Python: ``import volcaustics as vc; vc.measure("sphere1", seeds=2)``.

Each function runs what its command runs (``volcaustics measure``: the same runner, the
same result store, the same numbers) and returns typed results
(``reports.measuring.results.experiment``) instead of printing them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.measuring.experiment.measurement import MeasurementSettings
from volcaustics.reports.measuring.results.experiment import Experiment
from volcaustics.reports.measuring.results.sizing import REPORT_REFERENCE

if TYPE_CHECKING:
    from volcaustics.approx.params import ApproxParams
    from volcaustics.reports.measuring.runner import PointResult

__all__ = ["measure"]


def measure(scene: str, *, preset: str = "quick", seeds: int = 4, reference: ReferenceSettings | None = None,
            measurement: MeasurementSettings | None = None, progress: bool = False, **params: Any) -> Experiment:
    """Measure the approximation against the reference on one scene.

    Parameters
    ----------
    scene : str
        A built-in scene's name (``volcaustics scenes``) or the path of a TOML scene file.
    preset : str
        The approximation's preset (``quick``, ``paper``, ``best``, ``beams``); a preset
        that matches the paper's frame cost (``best``, ``beams``) does so here too, unless
        ``photon_res`` is given.
    seeds : int
        Frames with seeds ``seed`` … ``seed + seeds − 1`` (the approximation's own noise needs
        at least 2).
    reference : ReferenceSettings, optional
        The reference's budget; default the report's (``volcaustics measure``'s defaults).
    measurement : MeasurementSettings, optional
        How the experiment is measured; default the report's.
    progress : bool
        Show a progress bar.
    **params
        Approximation parameters by their names in ``approx/params.py`` (``photon_res=64``,
        ``width=96``, ``layers=2``, …), over the preset's.

    Returns
    -------
    Experiment
        Every metric, the decomposition of the caustic's error and the frame's cost, as
        frozen dataclasses; ``.images_table()`` and ``.decomposition_table()`` as pandas.

    Raises
    ------
    volcaustics.infra.errors.InputError
        A bad scene, preset or parameter value, naming it and what is allowed.

    Examples
    --------
    >>> import volcaustics as vc
    >>> e = vc.measure("sphere1", seeds=2)                      # doctest: +SKIP
    >>> e.metric("frame_relative_mse").debiased                 # doctest: +SKIP
    0.061
    """
    from volcaustics.approx.params import preset as preset_params

    point = measured_point(scene, preset_params(preset, **params), preset, seeds,
                           reference=reference or REPORT_REFERENCE, measurement=measurement or MeasurementSettings(),
                           photon_res_given="photon_res" in params, layers_given="layers" in params,
                           progress=progress)
    return Experiment.from_summary(point.summary, key=point.key, tables=point.tables)


def measured_point(scene: str, params: ApproxParams, preset: str, seeds: int, *, reference: ReferenceSettings,
                   measurement: MeasurementSettings, photon_res_given: bool, layers_given: bool,
                   progress: bool) -> PointResult:
    """One experiment as ``volcaustics measure`` and :func:`measure` run it: the settings
    checked, the values the preset takes from the scene resolved (layers, photon_res
    matched to the paper's cost), the point measured through the runner and its store
    (read back when stored), and for a matched preset its equal cost checked
    (``summary["equal_cost"]``)."""
    from volcaustics.approx.cost_match import equal_cost_check, with_auto_values
    from volcaustics.reports.measuring import runner
    from volcaustics.reports.measuring.experiment.point_checks import checked_settings
    from volcaustics.scenes import resolve_scene

    resolved = resolve_scene(scene)
    checked_settings(resolved, params, seeds)  # a bad seed count or size: before the cost match
    matched = with_auto_values(scene, params, preset, photon_res_given, layers_given=layers_given)
    checked_settings(resolved, matched, seeds)  # the matched frame too: before the reference
    run = runner.measure([runner.Point(scene, matched, seeds)], runner.results_store(), reference_settings=reference,
                         measurement=measurement, policy="continue", images=("layers",),
                         progress=progress)  # the layers image as the command writes it: one stored point for both
    point = run.results[0]
    point.summary["equal_cost"] = equal_cost_check(scene, matched, preset)
    return point
