"""`volcaustics report` renders what exists: catalogue previews and an HTML page."""

from __future__ import annotations

import json

import numpy as np

from reports.cli import main
from scenes.imageio import png_bytes, tonemap_srgb8


def test_report_renders_both_and_measures(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("VOLCAUSTICS_MI_VARIANT", "llvm_ad_rgb")
    out = tmp_path / "rep"
    assert main(["report", "--out", str(out), "--scenes", "refocus", "--width", "48", "--height", "40",
                 "--photons", "100000", "--spp", "8", "--batches", "2"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["approx_params"]["width"] == 48 and summary["reference_settings"]["height"] == 40
    row = summary["scenes"][0]
    assert row["scene"] == "refocus"
    errors = row["errors"]
    # the fog is the part both renderers compute almost identically (see test_cross_renderers)
    assert 0.9 < errors["fog"]["energy_ratio"] < 1.1
    assert errors["caustic"]["relative_mse"] > 0
    for path in row["images"].values():
        assert (out / path).read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    page = (out / "index.html").read_text()
    assert "refocus" in page and "relative MSE" in page
    assert "refocus" in capsys.readouterr().out
    assert not list(out.rglob(".*tmp*"))  # no temporary files left behind


def test_scene_check_writes_a_preview(tmp_path, write_scene, capsys):
    path = write_scene()
    assert main(["scenes", "--check", path, "--preview", str(tmp_path / "p")]) == 0
    assert (tmp_path / "p" / "base.png").read_bytes().startswith(b"\x89PNG")
    assert "preview ->" in capsys.readouterr().out


def test_preview_shows_the_objects(ctx):
    from approx.preview import render_preview
    from scenes import load_builtin

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

    from scenes.imageio import srgb_encode

    x = np.concatenate([np.linspace(0, 0.01, 101), np.linspace(0.01, 1, 1000)])
    assert np.allclose(srgb_encode(x), colour.cctf_encoding(x, function="sRGB"), atol=1e-12)


def test_report_and_reference_cli_share_one_cache_entry(tmp_path, monkeypatch):
    """Image size lives in the settings (DESIGN.md): the report's reference and
    `volcaustics reference --width/--height` at the same size are one render, one key,
    one cache entry — whichever path comes first, the other is served from the cache."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("VOLCAUSTICS_CACHE", str(cache))
    monkeypatch.setenv("VOLCAUSTICS_MI_VARIANT", "llvm_ad_rgb")
    size_and_budget = ["--width", "24", "--height", "24", "--photons", "100000", "--spp", "8", "--batches", "2"]
    assert main(["report", "--out", str(tmp_path / "rep"), "--scenes", "refocus", *size_and_budget]) == 0
    from_report = json.loads((tmp_path / "rep" / "summary.json").read_text())["scenes"][0]["reference"]
    assert main(["reference", "refocus", *size_and_budget, "-o", str(tmp_path / "r.exr")]) == 0
    from_cli = json.loads((tmp_path / "r.json").read_text())
    assert from_cli["key"] == from_report["key"]
    assert from_report["cached"] is False and from_cli["cached"] is True
    assert len(list((cache / "reference").glob("*.json"))) == 1
