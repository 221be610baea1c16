"""The harness from Python: ``import volcaustics as vc; vc.measure("sphere1", seeds=2)``.

Each function runs what its command runs (``volcaustics measure``, ``approx``,
``reference``, ``sweep``, ``frames``: the same code, the same result store, the same
numbers) and returns typed results instead of printing them: an
:class:`~volcaustics.experiment.result.Experiment`, a frame, a
reference, a sweep's or a frame check's result, with pandas tables and numpy images.

The renderers are ``render_approx`` and ``render_reference`` here, not
``vc.approx.render`` and ``vc.reference.render``: ``volcaustics.reference.render`` is the
reference renderer's package, and both take a scene's name where the packages' own
functions take a loaded ``Scene``.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from volcaustics.experiment.measurement import MeasurementSettings, measurement_settings
from volcaustics.experiment.result import Experiment
from volcaustics.experiment.sizing import reference_settings
from volcaustics.infra.errors import InputError
from volcaustics.reference.settings import ReferenceSettings
from volcaustics.reports.measuring.results.output_folders import check_output_set
from volcaustics.reports.studies.sweep.study_limits import FRAME_CHECK_SEEDS

if TYPE_CHECKING:
    import pandas as pd

    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.renderer import Frame
    from volcaustics.reference.cache import ReferenceResult
    from volcaustics.reports.measuring.runner import PointResult
    from volcaustics.reports.studies.sweep.sweep_run import SweepResult
    from volcaustics.scenes.model import Scene

__all__ = ["FrameCheck", "frames", "measure", "render_approx", "render_reference", "sweep"]


def measure(scene: str, *, preset: str = "quick", seeds: int = 4,
            reference: ReferenceSettings | Mapping[str, Any] | None = None,
            measurement: MeasurementSettings | Mapping[str, Any] | None = None, progress: bool = False,
            **params: Any) -> Experiment:
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
    reference : ReferenceSettings or mapping, optional
        The reference's budget, or a mapping of a spec file's ``[reference]`` keys over the
        report's (``volcaustics measure``'s defaults); its image size follows the frame's.
    measurement : MeasurementSettings or mapping, optional
        How the experiment is measured (or a mapping of a spec file's ``[measurement]`` keys,
        ``exact_subphotons``, ``subset_batches``, ``exact_steps``; a scope other than the
        report's, ``"decomposition"`` say, takes a MeasurementSettings); default the report's.
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

    scene = scene_argument(scene)
    point = measured_point(scene, preset_params(preset, **params), preset, seeds,
                           reference=reference if isinstance(reference, ReferenceSettings)
                           else reference_settings(_mapping(reference, "reference")),  # a spec's [reference] rule
                           measurement=_measurement(measurement),
                           photon_res_given="photon_res" in params, layers_given="layers" in params,
                           progress=progress)
    return point.experiment


def scene_argument(scene: object, argument: str = "scene") -> str:
    """A SCENE argument from Python: a name or a path (``str`` or a path object), as the
    string the commands take; InputError for anything else."""
    if isinstance(scene, os.PathLike):
        scene = os.fspath(scene)
    if not isinstance(scene, str) or not scene:
        raise InputError(f"{argument} = {scene!r}: expected a built-in scene's name or a scene file's path")
    return scene


def _reference(reference: object) -> ReferenceSettings:
    """``render_reference``'s settings: ReferenceSettings as it is, a mapping over the
    command's defaults (size fields included: the render is this size)."""
    base = ReferenceSettings()
    if reference is None:
        return base
    if isinstance(reference, ReferenceSettings):
        return reference
    if isinstance(reference, Mapping):
        try:
            return dataclasses.replace(base, **reference)
        except TypeError as exc:
            raise InputError(f"reference = {dict(reference)!r}: {exc}; expected ReferenceSettings' fields") from None
    raise InputError(f"reference = {reference!r}: expected ReferenceSettings or a mapping of its fields")


def _measurement(measurement: object) -> MeasurementSettings:
    if measurement is None or isinstance(measurement, MeasurementSettings):
        return measurement or MeasurementSettings()
    if isinstance(measurement, Mapping):
        return measurement_settings(dict(measurement), where="measurement")
    raise InputError(f"measurement = {measurement!r}: expected MeasurementSettings or a mapping of its fields")


def measured_point(scene: str, params: ApproxParams, preset: str, seeds: int, *, reference: ReferenceSettings,
                   measurement: MeasurementSettings, photon_res_given: bool, layers_given: bool,
                   progress: bool, resolved: Scene | None = None) -> PointResult:
    """One experiment as ``volcaustics measure`` and :func:`measure` run it: the settings
    checked, the values the preset takes from the scene resolved (layers, photon_res
    matched to the paper's cost), the point measured through the runner and its store
    (read back when stored), and for a matched preset its equal cost checked once and
    kept in the point's summary in the store (its experiment's ``equal_cost``). ``resolved``:
    ``scene`` resolved already (the command's); the scene is resolved once either way."""
    from volcaustics.experiment.point_checks import checked_settings
    from volcaustics.reports.measuring import runner
    from volcaustics.reports.measuring.cost_match import equal_cost_check, with_auto_values
    from volcaustics.scenes import resolve_scene

    resolved = resolved or resolve_scene(scene)
    checked_settings(resolved, params, seeds)  # a bad seed count or size: before the cost match
    matched = with_auto_values(scene, params, preset, photon_res_given, layers_given=layers_given, scene=resolved)
    checked_settings(resolved, matched, seeds)  # the matched frame too: before the reference
    store = runner.results_store()
    run = runner.measure([runner.Point(scene, matched, seeds, resolved=resolved)], store, reference_settings=reference,
                         measurement=measurement, policy="continue", images=("layers",),
                         progress=progress)  # the layers image as the command writes it: one stored point for both
    point = run.results[0]
    if point.experiment.equal_cost is None:
        check = equal_cost_check(scene, matched, preset)  # None: a preset not matched to the paper's cost
        if check is not None:  # the summary amended in the store, and read again (its experiment with it)
            point = dataclasses.replace(point, summary=store.amend_summary(point.key, {"equal_cost": check}))
    return point


def render_approx(scene: str, *, preset: str = "paper", **params: Any) -> Frame:
    """One frame of the paper's method (``volcaustics approx``).

    Parameters
    ----------
    scene : str
        A built-in scene's name or the path of a TOML scene file.
    preset : str
        ``paper`` (default), ``quick``, ``best`` or ``beams``; ``best`` and ``beams`` take
        the paper's frame cost on this scene (``photon_res``) and their layers from it.
    **params
        Approximation parameters by name (``photon_res=64``, ``width=128``, ``seed=3``, …).

    Returns
    -------
    Frame
        ``.images``: layer name → H×W×3 float32 (``caustic``, ``fog``, ``direct``,
        ``combined``, …); ``.timings``: seconds per pass; ``.params``: what rendered it.

    Examples
    --------
    >>> import volcaustics as vc
    >>> frame = vc.render_approx("refocus", width=64, height=64)   # doctest: +SKIP
    >>> frame.images["caustic"].shape                              # doctest: +SKIP
    (64, 64, 3)
    """
    from volcaustics.approx.params import preset as preset_params
    from volcaustics.approx.renderer import render
    from volcaustics.experiment.point_checks import check_denoiser
    from volcaustics.reports.measuring.cost_match import with_auto_values
    from volcaustics.scenes import resolve_scene

    scene = scene_argument(scene)
    resolved = resolve_scene(scene)
    chosen = preset_params(preset, **params)
    check_denoiser(chosen)
    return render(resolved, with_auto_values(scene, chosen, preset, "photon_res" in params,
                                             layers_given="layers" in params, scene=resolved))


def render_reference(scene: str, settings: ReferenceSettings | Mapping[str, Any] | None = None, *,
                     mode: str = "caustic",
                     progress: bool = False) -> ReferenceResult:
    """Ground truth from Mitsuba 3 (``volcaustics reference``), from the cache when an
    entry meets ``settings``, else rendered (or continued) and cached.

    Parameters
    ----------
    scene : str
        A built-in scene's name or the path of a TOML scene file.
    settings : ReferenceSettings or mapping, optional
        The budget and size (photons, spp, batches, width, height, target noise, …), or a
        mapping of those fields over the command's defaults; default the command's defaults.
    mode : str
        Which light paths the caustic layer counts (``caustic``: through glass).
    progress : bool
        Show a progress bar.

    Returns
    -------
    ReferenceResult
        ``.mean`` and ``.var``: layer name → H×W×3 float32 (the mean and its variance);
        ``.manifest``: photons, batches, seed, seconds, variant.

    Examples
    --------
    >>> import volcaustics as vc
    >>> from volcaustics.reference.settings import ReferenceSettings
    >>> r = vc.render_reference("refocus", ReferenceSettings(width=64, height=64))   # doctest: +SKIP
    >>> r.mean["caustic"].shape                                                    # doctest: +SKIP
    (64, 64, 3)
    """
    from volcaustics.reference.render import render_reference as render
    from volcaustics.scenes import resolve_scene

    return render(resolve_scene(scene_argument(scene)), _reference(settings), mode=mode,
                  progress=progress)


def sweep(output: str, *, spec: str | None = None, scenes: Sequence[str] | None = None,
          vary: Mapping[str, Sequence[Any]] | None = None, fixed: Mapping[str, Any] | None = None,
          preset: str | None = None, seeds: int | None = None,
          reference: ReferenceSettings | Mapping[str, Any] | None = None, measurement: Mapping[str, Any] | None = None,
          workers: int | None = None, dask: str | None = None, progress: bool = False) -> SweepResult:
    """A grid of experiments over approximation parameters (``volcaustics sweep``),
    resumable: points already in ``output``'s store are read back, not measured.

    Parameters
    ----------
    output : str
        The sweep's folder: its store, tables and figures.
    spec : str, optional
        A sweep spec TOML file (``docs/sweeps.md``); else the grid is given by ``vary``.
    scenes : sequence of str, optional
        Scene names or paths; default every built-in (with ``spec``: they replace its scenes).
    vary : mapping, optional
        Parameter name → the values to try (``{"layers": [1, 2, 4]}``).
    fixed : mapping, optional
        Parameter name → one value, for every point.
    preset, seeds : str, int, optional
        The points' preset (default ``quick``) and seeds (default 1: one frame each, so a
        point's debiased error still holds that frame's noise; 2 or more take it out).
    reference, measurement : mapping, optional
        A spec file's ``[reference]`` and ``[measurement]`` tables (``{"photons": 65536}``,
        ``{"exact_subphotons": 1}``, or ReferenceSettings): the reference's budget and how
        points are measured.
    workers, dask : int, str, optional
        Local worker processes, or a Dask scheduler's address.
    progress : bool
        Show a progress bar.

    Points run on worker processes that import the calling module again: call it from a
    notebook, or from a script under ``if __name__ == "__main__":`` (else every point
    fails, listed in ``failed``).

    Returns
    -------
    SweepResult
        ``.tables``: name → pandas table (``points``, …); counts of the points computed,
        read back and failed.

    Examples
    --------
    >>> import volcaustics as vc
    >>> result = vc.sweep("runs/layers", scenes=["refocus"], vary={"layers": [1, 2]})   # doctest: +SKIP
    >>> result.tables["points"][["layers", "caustic_relmse_debiased"]]                # doctest: +SKIP
    """
    from volcaustics.reports.measuring.pools.dask_address import parse_dask
    from volcaustics.reports.measuring.pools.executors import default_workers
    from volcaustics.reports.studies.sweep.sweep_run import OUTPUT_FILES, OUTPUT_FOLDERS, run_sweep
    from volcaustics.reports.studies.sweep.sweep_spec import SweepError, spec_from_document, spec_from_toml

    if spec is not None and any(x is not None for x in (vary, fixed, reference, measurement, preset, seeds)):
        raise SweepError(f"{spec}: the grid, preset, seeds, reference and measurement belong to the spec file; only "
                         f"scenes= may narrow it")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InputError(f"workers = {workers!r}: expected a number of worker processes, at least 1")
    if dask is not None:
        try:
            parse_dask(dask)
        except ValueError as exc:
            raise InputError(f"dask = {dask!r}: {str(exc).split(': ', 1)[-1]}") from None
    output = _output_folder(output, files=OUTPUT_FILES, folders=OUTPUT_FOLDERS, kind="sweep")
    if spec is not None:
        given = [scene_argument(x, "scenes") for x in _sequence(scenes, "scenes")] if scenes is not None else None
        grid = spec_from_toml(os.fspath(spec), None, given)
    else:
        doc: dict = {"vary": {k: list(v) if isinstance(v, tuple) else v for k, v in _mapping(vary, "vary").items()},
                     "set": _mapping(fixed, "fixed"), "reference": _reference_table(reference),
                     "measurement": _mapping(measurement, "measurement"), "preset": preset or "quick",
                     "seeds": 1 if seeds is None else seeds}
        if scenes is not None:
            doc["scenes"] = [scene_argument(x, "scenes") for x in _sequence(scenes, "scenes")]
        grid = spec_from_document(doc, "vc.sweep", None)
    return run_sweep(grid, output, workers=workers or default_workers(), dask=dask, progress=progress)


def _output_folder(folder: object, **expected: Any) -> str:
    """``folder`` as a path that can hold the outputs ``expected`` describes
    (``output_folders.check_output_set``); InputError before any work otherwise."""
    if isinstance(folder, os.PathLike):
        folder = os.fspath(folder)
    if not isinstance(folder, str):
        raise InputError(f"output = {folder!r}: expected a folder's path")
    check_output_set(folder, "output", **expected)
    return folder


def _mapping(value: object, argument: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise InputError(f"{argument} = {value!r}: expected a mapping of parameter names to values")
    return dict(value)


def _sequence(value: object, argument: str) -> list:
    if isinstance(value, (str, bytes, os.PathLike)) or not isinstance(value, Sequence):
        raise InputError(f"{argument} = {value!r}: expected a list")
    return list(value)


def _reference_table(reference: object) -> dict:
    """A sweep's ``[reference]`` table: a mapping as it is, ReferenceSettings as its fields
    that a spec file can set (REFERENCE_KEYS)."""
    from volcaustics.experiment.sizing import REFERENCE_KEYS

    if isinstance(reference, ReferenceSettings):
        return {k: getattr(reference, k) for k in REFERENCE_KEYS}
    return _mapping(reference, "reference")


@dataclass(frozen=True)
class FrameCheck:
    """A frame check (``volcaustics frames``): ``table``, one row per (scene,
    configuration, denoiser) with the one-frame error and the mean's bias against the
    paper's, its predicted cost and measured time; ``verdict``: the worst ratios per
    group of scenes against the goal (``goal``, ``met``)."""

    table: pd.DataFrame
    verdict: Mapping[str, Any]


def frames(output: str, *, scenes: Sequence[str] | None = None, seeds: int = FRAME_CHECK_SEEDS,
           progress: bool = False) -> FrameCheck:
    """The paper's configuration against ``best`` and ``beams`` at its frame cost, one
    frame's error per scene (``volcaustics frames``), resumable in ``output``.

    Parameters
    ----------
    output : str
        The check's folder: its result store (``points/``, every point's ``summary.json``
        and tables) and ``frames.parquet``.
    scenes : sequence of str, optional
        Scene names or paths; default every built-in and held-out scene.
    seeds : int
        Frames per configuration (2–64).
    progress : bool
        Show a progress bar.

    Returns
    -------
    FrameCheck
        The table and the verdict.

    Examples
    --------
    >>> import volcaustics as vc
    >>> check = vc.frames("runs/frames", scenes=["refocus"], seeds=2)   # doctest: +SKIP
    >>> check.table[["scene", "config", "frame_ratio"]]               # doctest: +SKIP
    """
    from volcaustics.reports.studies.best.frame_check import (
        FRAMES_FILE,
        KIND,
        MANIFEST,
        POINTS,
        default_scenes,
        run_frames,
        verdict,
    )

    if isinstance(seeds, bool) or not isinstance(seeds, int) or not 2 <= seeds <= 64:
        raise InputError(f"frames: seeds = {seeds!r}: expected an integer in [2, 64] (one frame's SE needs 2)")
    names = [scene_argument(x, "scenes") for x in _sequence(scenes, "scenes")] if scenes is not None else None
    if names is not None and not names:
        raise InputError("frames: scenes = []: expected at least one scene (None: every built-in and held-out one)")
    output = _output_folder(output, files=(FRAMES_FILE, MANIFEST), folders=(POINTS,), kind=KIND)
    table = run_frames(names if names is not None else default_scenes(), output, seeds=seeds, progress=progress)
    return FrameCheck(table, verdict(table))
