"""``volcaustics export SCENE --gltf OUT.glb|OUT.gltf`` (beside or instead of
``--mitsuba-xml``): what it writes and prints, and the usage errors (exit 2, before any
work, nothing written)."""

from __future__ import annotations

from pygltflib import GLTF2

from volcaustics.reports.cli import main


def test_glb_is_written(tmp_path, capsys):
    out = tmp_path / "x.glb"
    assert main(["export", "bunny", "--gltf", str(out)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.glb"]
    gltf = GLTF2().load(str(out))
    assert [n.name for n in gltf.nodes] == ["bunny", "floor", "spot_light", "camera"]
    assert capsys.readouterr().out.splitlines() == [
        f"export bunny -> {out} (glTF 2.0: 4 nodes, 2 meshes, 10002 triangles, 5006 vertices)"]


def test_gltf_writes_its_bin_beside_it(tmp_path, capsys):
    out = tmp_path / "x.gltf"
    assert main(["export", "sphere2", "--gltf", str(out)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.bin", "x.gltf"]
    assert GLTF2().load(str(out)).buffers[0].uri == "x.bin"
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[0].startswith(f"export sphere2 -> {out} (glTF 2.0: ")
    buffer = tmp_path / "x.bin"
    assert lines[1] == f"export sphere2 -> {buffer} (its buffer, {buffer.stat().st_size} bytes)"


def test_both_outputs_at_once(tmp_path, capsys):
    assert main(["export", "sphere2", "--mitsuba-xml", str(tmp_path / "s.xml"), "--gltf", str(tmp_path / "s.glb")]) == 0
    assert {"s.xml", "s_meshes", "s.glb"} == {p.name for p in tmp_path.iterdir()}
    assert len(capsys.readouterr().out.splitlines()) == 2


def test_another_extension_is_a_usage_error(tmp_path, capsys):
    assert main(["export", "bunny", "--gltf", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "--gltf" in err and "x.png" in err and ".glb" in err and ".gltf" in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())


def test_no_output_is_a_usage_error(capsys):
    assert main(["export", "bunny"]) == 2
    err = capsys.readouterr().err
    assert "--mitsuba-xml" in err and "--gltf" in err and "Traceback" not in err


def test_a_folder_where_the_bin_goes_is_refused(tmp_path, capsys):
    (tmp_path / "x.bin").mkdir()
    assert main(["export", "bunny", "--gltf", str(tmp_path / "x.gltf")]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.bin"]
