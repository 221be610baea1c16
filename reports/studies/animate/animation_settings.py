"""What an animation run renders: its reference budget, image size and seeds.

The budget keeps a built-in's default animation (24 frames) within about five minutes
cold on a 2-core machine: 128 pixels on the longer side, 2^22 photons and 32 camera
samples per pixel in 8 batches per frame, no noise target (3–5 s per frame here; the
caustic's noise floor 0.04–0.1%, the fog's 0.3%: docs/decisions.md "Dynamic scenes").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from volcaustics.reference.settings import ReferenceSettings

if TYPE_CHECKING:
    from volcaustics.scenes.model import Camera

ANIMATION_SIZE = 128  # pixels on the longer side when no width/height is given
ANIMATION_REFERENCE = ReferenceSettings(photons=1 << 22, spp=32, batches=8, target_noise=None, max_seconds=600.0)
SEED_MODES = ("fixed", "per-frame")
DEFAULT_CHAINS = 2  # independent sequences per seed mode: the approximation's own noise needs 2


REFERENCE_SEED_STRIDE = 1_000_003  # prime: the frames of runs whose base seeds differ by less never share a seed


def reference_seed(base: int, frame: int) -> int:
    """The reference's seed for ``frame``: its own per frame, so that the frames' noise is
    independent, which the flicker's debiasing assumes (metrics.temporal). With one seed
    for all frames, batch b of every frame draws the same random numbers: neighbouring
    frames' noise correlates and Σ(v_t + v_{t−1}) over-subtracts (two references of
    refocus scored z = −4.5 on the caustic, −8.7 on the fog)."""
    return (base + REFERENCE_SEED_STRIDE * frame) % 2**31


def chain_seed(mode: str, base: int, chain: int, chains: int, frame: int) -> int:
    """The approximation's seed of ``chain`` at ``frame``: ``fixed`` keeps one seed per chain
    (base + chain) over the whole animation; ``per-frame`` advances it every frame
    (base + chain + chains·(frame + 1)), never a fixed chain's seed."""
    if mode == "fixed":
        return base + chain
    if mode == "per-frame":
        return base + chain + chains * (frame + 1)
    raise ValueError(f"seed mode {mode!r}: expected one of {', '.join(SEED_MODES)}")


def animation_size(camera: Camera) -> tuple[int, int]:
    """(width, height) with the camera's aspect, ANIMATION_SIZE on the longer side."""
    scale = ANIMATION_SIZE / max(camera.width, camera.height)
    return max(1, round(camera.width * scale)), max(1, round(camera.height * scale))


def frame_list(text: str | None, frames: int) -> list[int]:
    """The frames to render: all (None); ``N`` evenly spaced over the animation, first and
    last included (every frame when N ≥ frames); or a slice ``A:B[:STEP]`` of 0 … frames − 1
    whose bounds lie in the animation. ValueError names the fix."""
    every = list(range(frames))
    if text is None:
        return every
    text = text.strip()
    try:
        if ":" in text:
            parts = [int(p) if p.strip() else None for p in text.split(":")]
            if len(parts) > 3 or (len(parts) == 3 and parts[2] is not None and parts[2] <= 0):
                raise ValueError
            if any(p is not None and not -frames <= p <= frames for p in parts[:2]):
                raise IndexError
            chosen = every[slice(*parts)]
        else:
            n = int(text)
            if n < 1:
                raise ValueError
            n = min(n, frames)  # more than the animation has: every frame
            chosen = sorted({round(i * (frames - 1) / max(n - 1, 1)) for i in range(n)})
    except IndexError:
        raise ValueError(f"--frames = {text!r}: the animation has frames 0 … {frames - 1} only: a slice A:B with "
                         f"A and B in [{-frames}, {frames}]") from None
    except ValueError:
        raise ValueError(f"--frames = {text!r}: expected a count N ≥ 1 or a slice A:B[:STEP] of frames "
                         f"0 … {frames - 1} (STEP > 0)") from None
    if not chosen:
        raise ValueError(f"--frames = {text!r}: selects no frame of 0 … {frames - 1}")
    return chosen


# ColorVideoVDP: not installed, and the reason is reported with every run.
CVVDP_SKIPPED = ("ColorVideoVDP (pip cvvdp 0.5.7) not measured: it needs PyTorch, and PyPI's torch 2.15 brings "
                 "about 3 GB of CUDA 13 wheels (nvidia-cudnn, cublas, nccl, ...); the CPU-only build is only on "
                 "download.pytorch.org, outside the registries this project installs from. Run it on "
                 "DIR/animation.mp4 against a reference video where PyTorch is available.")
