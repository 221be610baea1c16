"""``volcaustics animate``: a scene's ``[animation]`` measured over time (docs/over-time.md):
``settings`` (the reference budget, size, seeds), ``run`` (frames
through one Renderer and the reference cache, resumable), ``metrics`` (per-frame and
temporal tables), ``media`` (the side-by-side video and the plot), ``write`` (the set)."""
