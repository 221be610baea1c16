"""The files of one render command: ``OUT.exr`` as given (its extension's case kept) and
its siblings named after its stem."""

from __future__ import annotations


def render_outputs(out: str, siblings: dict) -> dict:
    """{"exr": out, name: stem + suffix for each of ``siblings`` (name → suffix)}; the
    stem is ``out`` less its ``.exr`` (any case) — `-o shot.EXR` writes shot.EXR and
    shot.png, never shot.exr."""
    stem = out[:-4] if out.lower().endswith(".exr") else out
    return {"exr": out if out.lower().endswith(".exr") else out + ".exr",
            **{name: stem + suffix for name, suffix in siblings.items()}}
