"""Heterogeneous media measured: the paper's claim that its photon tracing "can handle
[inhomogeneous media] easily with small tweak" (§6), on fogbank, smoke (scenes/media) and layered_fog (held out).

For each scene and configuration (the paper's points at the report's ``quick`` preset, and
``--preset beams``), through the public API (``vc.measure``, the report's reference
settings, 4 seeds, 128²):
the caustic's one-frame relative MSE and its mean image's (the bias), the fog's (the
transmittance volumes' error: the fog has no photons), the decomposition's closure (its
residual's z for energy and relMSE), the frame's wall time and its ``volumes`` pass, and for
the beams preset its cost against the paper configuration's (predicted under every weight set
that prices it, and measured: ``equal_cost``). Then the
transmittance approximations' own cost: the volumes and the march at a quarter and at four
times their defaults on the first scene, at a quarter on smoke's sharp plume; the
decomposition's ``march`` and ``camera_volume`` terms (energy share ± SE / debiased part of
the relMSE, in points) say what each costs. Then the homogeneous comparison: each scene with its
density dropped (ρ ≡ 1: the same coefficients everywhere).

    .venv/bin/python bench/heterogeneous_media.py [--scenes fogbank,smoke,layered_fog] [--seeds 4]

Prints a Markdown table per part (docs/decisions.md "Heterogeneous media" holds the figures).
Results are stored in the result store as every measure's: a second run reads them back.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile


def _scene_path(name: str) -> str:
    """A media scene's file: fogbank and smoke are named media scenes, layered_fog is held out."""
    from volcaustics.scenes import SceneError
    from volcaustics.scenes.catalogue import HELDOUT_NAMES, MEDIA_NAMES, heldout_path, named_path

    path = heldout_path(name) if name in HELDOUT_NAMES else named_path(name) if name in MEDIA_NAMES else None
    if path is None:
        raise SceneError(None, "--scenes", name, f"expected a media scene ({', '.join(MEDIA_NAMES)}) or layered_fog")
    return path


def _row(label: str, result) -> str:
    from volcaustics.experiment.result import find_estimate

    def pct(metric: str, component: str) -> str:
        e = find_estimate(result.images, metric, component)
        return "–" if e is None or e.debiased != e.debiased else f"{100 * e.debiased:.2f}%"  # NaN: no such light

    def term(name: str) -> str:
        rows = [r for r in result.decomposition if r.term == name]
        return "–" if not rows else (f"{100 * rows[0].energy_share:+.2f} ± {100 * rows[0].energy_share_se:.2f}% / "
                                     f"{100 * rows[0].relmse_part_debiased:+.2f}")

    closure = result.closure
    z = "–" if closure is None else f"{closure.energy_z:+.1f} / {closure.relmse_z:+.1f}"
    t = result.timings
    match = result.equal_cost
    cost = "–" if match is None else (", ".join(f"{name} {v:.2f}" for name, v in match.predicted_ratio.items())
                                      + f"; measured {match.measured_ratio:.2f}")
    return (f"| {label} | {pct('frame_relative_mse', 'caustic')} | {pct('relative_mse', 'caustic')} | "
            f"{pct('relative_mse', 'fog')} | {term('march')} | {term('camera_volume')} | {z} | "
            f"{1000 * t.get('frame_wall', float('nan')):.0f} | {1000 * t.get('volumes', 0.0):.1f} | {cost} |")


HEADER = ("| configuration | caustic one frame | caustic mean image | fog | march (energy / relMSE part) "
          "| camera_volume (energy / relMSE part) | residual z (energy / relMSE) | frame (ms) | volumes (ms) "
          "| × the paper's cost (predicted per weight set; measured) |\n|---|---|---|---|---|---|---|---|---|---|")


def _homogeneous(path: str, folder: str) -> str:
    """A copy of the scene file ``path`` without its [medium.density] table, in ``folder``."""
    import tomli_w
    import tomllib

    with open(path, "rb") as fh:
        doc = tomllib.load(fh)
    doc["medium"].pop("density")
    doc["name"] = doc["name"] + "_homogeneous"
    out = os.path.join(folder, os.path.basename(path).replace(".toml", "_homogeneous.toml"))
    with open(out, "wb") as fh:
        fh.write(tomli_w.dumps(doc).encode())
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default="fogbank,smoke,layered_fog")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--size", type=int, default=128, help="image width and height (pixels)")
    args = parser.parse_args(argv)
    import volcaustics as vc

    size = {"width": args.size, "height": args.size}
    scenes = [_scene_path(name) for name in args.scenes.split(",")]
    print("## Points and beams\n")
    print(HEADER)
    for path in scenes:
        name = os.path.basename(path)[:-5]
        for preset in ("quick", "beams"):
            print(_row(f"{name}, {preset}", vc.measure(path, preset=preset, seeds=args.seeds, **size)), flush=True)
    print("\n## The transmittance approximations (points)\n")
    print(HEADER)
    coarse = {"march_steps": 4, "light_volume_res": 32, "light_volume_slices": 16, "camera_volume_res": 32,
              "camera_volume_slices": 16}
    fine = {"march_steps": 64, "light_volume_res": 512, "light_volume_slices": 256, "camera_volume_res": 512,
            "camera_volume_slices": 256}
    smoke = _scene_path("smoke")
    for path, label, values in ((scenes[0], "a quarter", coarse), (scenes[0], "four times", fine),
                                (smoke, "a quarter", coarse)):
        result = vc.measure(path, preset="quick", seeds=args.seeds, **size, **values)
        print(_row(f"{os.path.basename(path)[:-5]}: volumes and march at {label} the defaults", result), flush=True)
    print("\n## The same scenes homogeneous (ρ ≡ 1)\n")
    print(HEADER)
    with tempfile.TemporaryDirectory() as folder:
        for path in scenes:
            plain = _homogeneous(path, folder)
            result = vc.measure(plain, preset="quick", seeds=args.seeds, **size)
            print(_row(f"{os.path.basename(plain)[:-5]}, quick", result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

