"""Are two runs' results the same numbers? For refactors: run the same `measure` or sweep
with the code before and after, then compare.

    .venv/bin/python bench/bit_identity.py rekey CACHE_BEFORE CACHE_AFTER
    .venv/bin/python bench/bit_identity.py compare DIR_BEFORE DIR_AFTER

``rekey`` copies a reference cache to a new one under the keys this code computes: the
reference key hashes the code under reference/render/, so a refactor that touches it
renders anew, and the light tracer's float32 atomic splats differ in the last bits from
run to run (docs/decisions.md "Float32 atomic splats"); the copied entries are the very same
pixels. ``compare`` byte-compares
the tables of two result folders (a `measure -o DIR` or a sweep store) without the columns
that name the code or the run: code_version, reference_key and point (they hash the code)
and every time (``*_time_s``); rows in the order of scene and the varied parameters (a sweep orders
its tables by point key). Exit 0 when every table is identical.
"""

from __future__ import annotations

import argparse
import glob
import hashlib
import json
import os
import shutil
import sys

VOLATILE = ("code_version", "reference_key", "point")  # and every column of seconds (*_time_s): the clock
ORDER = ("scene", "photon_res", "layers", "layer_strategy", "iterations", "peak_samples", "steps", "splat_radius",
         "light_res", "width", "height", "fog_steps", "fresnel", "seed")


def rekey(src: str, dst: str) -> None:
    """Copy the reference cache ``src`` to ``dst``, every entry also under the key this code
    computes: its data files (named in the manifest's ``files``) linked under the new key's
    names, the manifest rewritten with the new key and file names and sealed again."""
    shutil.copytree(src, dst, dirs_exist_ok=True)
    os.environ["VOLCAUSTICS_CACHE"] = dst
    from volcaustics.infra.storage import document_sha256
    from volcaustics.reference import cache
    from volcaustics.reference.settings import ReferenceSettings
    from volcaustics.scenes import resolve_scene

    folder = os.path.join(dst, "reference")
    for path in glob.glob(os.path.join(src, "reference", "*.json")):
        with open(path) as fh:
            manifest = json.load(fh)
        scene = resolve_scene(manifest["scene"])
        new = cache.cache_key(scene, ReferenceSettings(**manifest["settings"]), mode=manifest["mode"],
                              variant=manifest["mitsuba_variant"])
        old = manifest["key"]
        files = {}
        for role, name in (manifest.get("files") or {}).items():
            renamed = new + name[len(old):] if name.startswith(old) else name
            target = os.path.join(folder, renamed)
            if not os.path.exists(target):
                os.link(os.path.join(src, "reference", name), target)
            files[role] = renamed
        moved = {**manifest, "key": new, "files": files}
        moved[cache.SEAL] = document_sha256(moved, cache.SEAL)
        with open(os.path.join(folder, new + ".json"), "w") as fh:
            json.dump(moved, fh, indent=2)
        print(f"{manifest['scene']:<12} {old[:12]} -> {new[:12]}")


def _stable(frame):
    frame = frame.drop(columns=[c for c in frame.columns if c in VOLATILE or c.endswith("_time_s")])
    order = [c for c in ORDER if c in frame.columns]
    return frame.sort_values(order, kind="stable").reset_index(drop=True) if order else frame


def compare(before: str, after: str) -> bool:
    import pandas as pd

    same = True
    names = sorted(os.path.basename(p) for p in glob.glob(os.path.join(before, "*.parquet")))
    for name in names:
        a, b = (_stable(pd.read_parquet(os.path.join(folder, name))) for folder in (before, after))
        ha, hb = (hashlib.sha256(f.to_csv(index=False).encode()).hexdigest()[:16] for f in (a, b))
        equal = list(a.columns) == list(b.columns) and a.equals(b) and ha == hb
        same &= equal
        print(f"{name:<18} rows {len(a):>6} columns {len(a.columns):>3} sha256 {ha} vs {hb} "
              f"{'identical' if equal else 'DIFFERENT'}")
    return same and bool(names)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("action", choices=("rekey", "compare"))
    parser.add_argument("before")
    parser.add_argument("after")
    args = parser.parse_args()
    if args.action == "rekey":
        rekey(args.before, args.after)
        return 0
    return 0 if compare(args.before, args.after) else 1


if __name__ == "__main__":
    sys.exit(main())
