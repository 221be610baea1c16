"""An animation's pictures: the side-by-side video (approximation | reference | per-pixel
relative MSE of the combined image) as MP4 (imageio-ffmpeg, H.264) and as an animated
WebP (Pillow; GIF where Pillow lacks WebP) that the report embeds, and the plot of the
per-frame errors and the flicker over time."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from volcaustics.infra.imageio import auto_exposure, tonemap_srgb8
from volcaustics.metrics import image as im
from volcaustics.reports.presenting.figures.plotting import OKABE_ITO, png_bytes, pyplot
from volcaustics.reports.presenting.figures.scales import SCALES, heatmap_rgb8
from volcaustics.reports.studies.animate.animation_metrics import keep_masks

if TYPE_CHECKING:
    from volcaustics.reports.studies.animate.animation_frames import AnimationFrames

BLOCK = 16  # H.264 macroblock: frames are padded to a multiple (black), never resampled
LAYER = "combined"


def video_frames(run: AnimationFrames, mode: str) -> list:
    """One H×3W×3 uint8 picture per frame: chain 0 of ``mode`` | the reference | its error
    map (SCALES["per_pixel_relative_mse"]), at one exposure for the whole animation (the
    reference frames' 99.5th luminance percentile), padded to BLOCK."""
    references = np.stack([r.mean[LAYER] for r in run.references])
    exposure = auto_exposure(references.reshape(-1, references.shape[2], 3))
    keep = keep_masks(run, mode)
    pictures = []
    for i, reference in enumerate(references):
        approx = run.approx[mode][LAYER][0, i]
        try:
            error = im.per_pixel_relative_mse(reference, approx, mask=keep[i], full=True)["map"]
        except ValueError:  # a black reference frame: nothing compared
            error = np.full(reference.shape[:2], np.nan)
        row = np.concatenate([tonemap_srgb8(approx, exposure), tonemap_srgb8(reference, exposure),
                              heatmap_rgb8(error, SCALES["per_pixel_relative_mse"])], axis=1)
        pictures.append(_padded(row))
    return pictures


def _padded(picture: np.ndarray) -> np.ndarray:
    h, w = picture.shape[:2]
    out = np.zeros((-(-h // BLOCK) * BLOCK, -(-w // BLOCK) * BLOCK, 3), np.uint8)
    out[:h, :w] = picture
    return out


def write_mp4(path: str, pictures: list, fps: float) -> None:
    import imageio.v2 as imageio

    with imageio.get_writer(path, format="FFMPEG", fps=fps, codec="libx264", pixelformat="yuv420p", quality=8,
                            macro_block_size=BLOCK, ffmpeg_log_level="error") as writer:
        for picture in pictures:
            writer.append_data(picture)  # type: ignore[attr-defined]  # imageio's FFMPEG writer


def web_format() -> str:
    """"webp" where Pillow writes animated WebP, else "gif"."""
    from PIL import features

    return "webp" if features.check("webp") else "gif"


def write_web(path: str, pictures: list, fps: float, fmt: str) -> None:
    """The animation for the page: looping, lossy WebP (quality 85) or a GIF."""
    from PIL import Image

    frames = [Image.fromarray(p) for p in pictures]
    options = {"quality": 85, "method": 4} if fmt == "webp" else {"optimize": False}
    frames[0].save(path, format=fmt.upper(), save_all=True, append_images=frames[1:],
                   duration=max(int(round(1000.0 / fps)), 20), loop=0, **options)


def plot_png(run: AnimationFrames, frames: list, temporal: list) -> bytes:
    """Two panels over time: each frame's caustic and combined debiased relative MSE,
    and each frame pair's flicker (± SE), per seed mode."""
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 5.6), sharex=True)
    styles = {"caustic": "-", "combined": "--"}
    for k, mode in enumerate(run.modes):
        colour = OKABE_ITO[k % len(OKABE_ITO)]
        for component, style in styles.items():
            series = sorted((r["time_s"], r["debiased"]) for r in frames if r["seed_mode"] == mode
                            and r["component"] == component and r["metric"] == "relative_mse")
            if series:
                t, v = zip(*series)
                top.plot(t, 100 * np.asarray(v, float), style, color=colour, label=f"{component}, {mode} seed")
            pairs = sorted((r["time_s"], r["flicker"], r["flicker_se"]) for r in temporal if r["seed_mode"] == mode
                           and r["component"] == component and np.isfinite(r["flicker"]))
            if pairs:
                t, v, se = zip(*pairs)
                bottom.errorbar(t, 100 * np.asarray(v), yerr=100 * np.asarray(se), fmt=style, color=colour,
                                capsize=2, label=f"{component}, {mode} seed")
    top.set_ylabel("relative MSE, debiased (%)")
    bottom.set_ylabel("flicker per frame pair (%)")
    bottom.set_xlabel("time (s)")
    for ax in (top, bottom):
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.grid(alpha=0.3)
    top.legend(fontsize=7, ncol=2)
    top.set_title(f"{run.scene.name}: error per frame and frame-to-frame (approximation vs reference)", fontsize=9)
    return png_bytes(fig, dpi=110)
