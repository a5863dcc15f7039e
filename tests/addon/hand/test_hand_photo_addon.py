"""A new hand from a photograph (thesis 6.2.3) end to end: a rendered photo of a scaled hand with a ruler,
the feature points clicked on it, ``build-hand --photo --points`` and the proportions of the result; bad
clicks refused by the command line, with nothing written."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from conftest import addon_module, run_fh

STRETCH = np.diag([1.0, 0.93, 1.12])        # narrower and longer than the reference hand
SIZE = (900, 1100)


def _photo(bpy, tmp_path: Path) -> tuple[Path, Path, dict]:
    """Render the scaled reference hand from the back along its plane's normal with a 200 mm ruler, and
    write the pixel positions of its 26 feature points and the ruler's 0 and 20 cm marks."""
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector
    assert bpy.ops.faces_hands.build_hand_rig() == {"FINISHED"}
    obj = bpy.context.active_object
    rig = addon_module("operators.adapters.rig_store").get_rig(obj, "hand")
    obj.scale = tuple(np.diag(STRETCH))
    features = {k: STRETCH @ v for k, v in rig.feature_points().items()}
    points = np.array(list(features.values()))
    x = points - points.mean(axis=0)
    normal = np.linalg.eigh(x.T @ x)[1][:, 0]
    normal *= -np.sign(normal[0])                     # from the back of the hand (-X side)
    up = np.array([0.0, 0.0, 1.0]) - normal[2] * normal
    up /= np.linalg.norm(up)
    right = np.cross(normal, up)
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    ruler = bpy.context.active_object
    start = points.mean(axis=0) - 0.1 * right - 0.13 * up + 0.03 * normal
    ruler.scale = (0.2, 0.004, 0.012)
    ruler.location = tuple(start + 0.1 * right)
    ruler.rotation_euler = Vector(right).to_track_quat("X", "Z").to_euler()
    scene = bpy.context.scene
    render = addon_module("operators.adapters.render")
    render.setup_workbench(scene, SIZE)
    camera_data = bpy.data.cameras.new("photo")
    camera_data.type, camera_data.ortho_scale = "ORTHO", 0.3
    camera = bpy.data.objects.new("photo", camera_data)
    scene.collection.objects.link(camera)
    camera.location = tuple(points.mean(axis=0) + 0.5 * normal)
    camera.rotation_euler = Vector(-normal).to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    for o in scene.objects:
        o.hide_render = o not in (obj, ruler)
    png = tmp_path / "hand_photo.png"
    scene.render.filepath = str(png)
    bpy.ops.render.render(write_still=True)
    bpy.context.view_layer.update()

    def pixel(p):
        u, v, _ = world_to_camera_view(scene, camera, Vector(p))
        return [float(u * SIZE[0]), float((1 - v) * SIZE[1])]

    doc = {"format": "faces_hands.hand_photo_points", "version": 1, "image": png.name,
           "points": {k: pixel(v) for k, v in features.items()},
           "ruler": [pixel(start), pixel(start + 0.2 * right)], "ruler_mm": 200.0}
    path = tmp_path / "hand_points.json"
    path.write_text(json.dumps(doc, indent=1))
    return png, path, features


def test_the_warped_hand_from_a_photo_has_the_photographed_proportions(bpy_clean, installed, tmp_path):
    bpy = bpy_clean
    png, points, features = _photo(bpy, tmp_path)
    assert png.stat().st_size > 10_000
    out = tmp_path / "photo_hand.blend"
    result = run_fh(installed, "build-hand", "--photo", png, "--points", points, "--out", out)
    assert result.returncode == 0, result.stderr
    bpy.ops.wm.open_mainfile(filepath=str(out))
    store = addon_module("operators.adapters.rig_store")
    rig = store.get_rig(store.find_rig(bpy.data.objects, None, "hand"), "hand")
    warped = rig.feature_points()
    pairs = [("index_mcp", "pinky_mcp"), ("ulna_head", "middle_tip"), ("wrist_radial", "wrist_ulnar"),
             ("thumb_tip", "pinky_tip"), ("index_mcp", "index_tip"), ("middle_pip", "middle_dip"),
             ("thumb_mcp", "thumb_tip"), ("ring_mcp", "ring_pip")]
    ratios = {f"{a}-{b}": float(np.linalg.norm(warped[a] - warped[b]) / np.linalg.norm(features[a] - features[b]))
              for a, b in pairs}
    assert all(abs(r - 1.0) < 0.03 for r in ratios.values()), ratios
    assert rig.photo["image"].endswith("hand_photo.png")


def _points(tmp_path, mutate):
    doc = {"format": "faces_hands.hand_photo_points", "version": 1,
           "points": {n: [500.0 + 10 * i, 100.0 + 30 * i] for i, n in enumerate(
               ["ulna_head", "wrist_radial", "wrist_ulnar", "index_mcp", "index_pip", "index_dip", "index_tip",
                "middle_mcp", "middle_pip", "middle_dip", "middle_tip", "ring_mcp", "ring_pip", "ring_dip",
                "ring_tip", "pinky_tip"])}, "ruler": [[0.0, 0.0], [800.0, 0.0]], "ruler_mm": 200.0}
    mutate(doc)
    path = tmp_path / "points.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d["points"].pop("pinky_tip"), "only 15 feature points"),
    (lambda d: d.update(ruler=[[10.0, 10.0], [10.0, 10.0]]), "ruler marks are 0 pixels apart"),
    (lambda d: d["points"].update(index_tip=[500.0, 100.0]), "impossible order"),
])
def test_build_hand_refuses_bad_clicks_and_writes_nothing(installed, tmp_path, mutate, message):
    png = tmp_path / "photo.png"
    png.write_bytes(b"not really a png")
    out = tmp_path / "hand.blend"
    result = run_fh(installed, "build-hand", "--photo", png, "--points", _points(tmp_path, mutate), "--out", out)
    assert result.returncode == 1 and message in result.stderr, result.stderr
    assert result.stderr.strip().splitlines()[-1].startswith("faces_hands: error:")
    assert not out.exists()


def test_animate_hand_refuses_contractions_outside_0_1(installed, tmp_path):
    user = Path(installed.user_dir) / "extensions" / ".user" / "user_default" / "faces_hands" / "presets" / "hand"
    user.mkdir(parents=True, exist_ok=True)
    shipped = json.loads((installed.extension_dir / "presets" / "hand" / "poses.json").read_text())
    shipped["poses"]["fist"]["contractions"]["flexor_digitorum_profundus_index"] = 1.5
    (user / "poses.json").write_text(json.dumps(shipped))
    out = tmp_path / "fist.glb"
    try:
        result = run_fh(installed, "animate-hand", "--preset", "fist", "--out", out)
    finally:
        (user / "poses.json").unlink()
    assert result.returncode == 1 and "outside [0, 1]" in result.stderr, result.stderr
    assert not out.exists()
