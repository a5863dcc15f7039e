"""Default assets reach Blender through the installed add-on."""
import pytest

pytestmark = pytest.mark.smoke


def test_add_default_assets_operator(bpy_clean):
    bpy = bpy_clean
    assert bpy.ops.faces_hands.add_default_assets() == {"FINISHED"}
    objects = {o.name: o for o in bpy.data.objects}
    assert len(objects["FH Canonical Face"].data.vertices) == 468
    assert len(objects["FH Skull"].data.vertices) == 3305
    assert len(objects["FH Jaw"].data.vertices) == 1459
    assert objects["FH Canonical Face"].data.uv_layers, "UVs lost on the way into Blender"


def test_info_command_lists_bundled_packages(installed):
    from conftest import run_fh
    result = run_fh(installed, "info")
    assert result.returncode == 0, result.stderr
    import tomllib
    from conftest import ROOT
    scipy = next(w.split("-")[1] for w in tomllib.loads((ROOT / "blender_manifest.toml").read_text())["wheels"]
                 if w.split("/")[-1].startswith("scipy-"))
    for package in (f"scipy {scipy}", "soundfile", "espeakng_loader", "pocketsphinx"):
        assert package in result.stdout, result.stdout
    assert "MISSING" not in result.stdout
    assert "canonical face: 468 vertices" in result.stdout
