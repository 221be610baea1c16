"""Scene previews (`volcaustics scenes --preview`) and the PNG/sRGB encoding every
picture of the harness goes through."""

from __future__ import annotations

import numpy as np

from volcaustics.infra.imageio import png_bytes, tonemap_srgb8
from volcaustics.reports.cli import main


def test_scene_check_writes_a_preview(tmp_path, write_scene, capsys):
    path = write_scene()
    assert main(["scenes", "--check", path, "--preview", str(tmp_path / "p")]) == 0
    assert (tmp_path / "p" / "base.png").read_bytes().startswith(b"\x89PNG")
    assert "preview ->" in capsys.readouterr().out


def test_preview_shows_the_objects(ctx):
    from volcaustics.approx.preview import render_preview
    from volcaustics.scenes import load_builtin

    image = render_preview(ctx, load_builtin("refocus"), 64, 64)
    assert image.shape == (64, 64, 3) and np.isfinite(image).all() and image.min() >= 0
    # The sphere (centre projected near the image centre, slightly above) is lit; the top rows are sky.
    assert image[20:30, 28:36].mean() > 0 and image[:4].max() == 0


def test_png_encoding_round_trip():
    zlib_image = tonemap_srgb8(np.full((3, 2, 3), 0.5, np.float32), exposure=1.0)
    assert zlib_image[0, 0, 0] == 188  # sRGB OETF(0.5) = 0.7354 -> 188
    import zlib

    data = png_bytes(zlib_image)
    idat = data[data.index(b"IDAT") + 4:]
    raw = zlib.decompress(idat[: int.from_bytes(data[data.index(b"IDAT") - 4:data.index(b"IDAT")], "big")])
    assert raw == b"".join(b"\x00" + bytes([188] * 6) for _ in range(3))


def test_srgb_encoding_matches_colour_science():
    import colour

    from volcaustics.infra.imageio import srgb_encode

    x = np.concatenate([np.linspace(0, 0.01, 101), np.linspace(0.01, 1, 1000)])
    assert np.allclose(srgb_encode(x), colour.cctf_encoding(x, function="sRGB"), atol=1e-12)
