# SPDX-License-Identifier: GPL-3.0-or-later
"""Every file we write, read back: where the exports put each vertex, and what the takes' formats return.

**Exports in place** (issue 33 item 4). Rigs made the way an artist makes them, through the installed
extension's operators: the default face and a fitted head (the MakeHuman head of ``tests/data/heads`` written
as a Y-up OBJ in decimetres and imported by Blender's OBJ importer, which turns it 90 degrees: as imported,
and with that rotation and scale applied before fitting), each speaking a line with non-verbal behaviour (the
head moves as a delta rotation) baked as weights; the reference hand baked with a motion; a morphable face.
Each is exported as it stands and again turned, scaled, put under a moving Empty and (one case) in a
centimetre scene. Every GLB and FBX is read back by Blender's own importers into an empty scene, and every
GLB is also played by three.js in Debian's headless chromium (``bench/client``, every vertex of every mesh,
morph targets and skinning applied by three.js); each part's vertices are compared with the scene's, in
metres, at the first frame and three animated ones (``tests/export_checks.py``: vertices matched over their
whole trajectory). Limit: 0.1 mm.

**Formats read back** (item 5): the face take's Live Link Face CSV (frames and weights), its Rhubarb cues (TSV
and JSON), its GLB and FBX through ``retarget`` (weights at every frame), the hand FBX (bones, vertex groups,
keyed bones) and ``--set`` (the attribute value it leaves).

``.venv/bin/python bench/roundtrip.py [--quick]`` (needs ``make install`` and ``make bench-client``;
``--quick``: no fitted heads). three.js's pictures of each rig's turned GLB (front, side, back, at the second
animated frame) go to ``out/bench/roundtrip/``. The last line is ``RESULT key=value ...``; the exit code is 1
when any export misplaces a vertex by more than 0.1 mm or a format does not read back.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import _harness  # noqa: E402  (the installed extension)
import bpy  # noqa: E402
import export_checks as checks  # noqa: E402
import gltf_client as client  # noqa: E402
import numpy as np  # noqa: E402

OUT = _harness.ROOT / "out" / "bench" / "roundtrip"
HEAD = _harness.ROOT / "tests" / "data" / "heads" / "makehuman_neutral.npz"
LINE = "Papa made a map, and Bob is happy."
LIMIT_MM = 0.1
FPS = 30


def module(name):
    return _harness.addon_module(name)


# ----------------------------------------------------------------------------------------- the rigs
def _speak(rig) -> None:
    """A line with behaviour (the head turns: a delta rotation) on ``rig``, baked as weights."""
    scene = bpy.context.scene
    scene.render.fps, scene.frame_start = FPS, 1
    settings = scene.faces_hands
    settings.behavior_style, settings.behavior_seed = "expressive", 2
    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.faces_hands.speak_text(text=LINE) == {"FINISHED"}
    keys = [k.co[0] for c in module("operators.adapters.fcurves").existing_channelbag(rig).fcurves
            for k in c.keyframe_points]
    scene.frame_end = int(math.ceil(max(keys)))
    assert bpy.ops.faces_hands.bake_face(mode="ANIMATION") == {"FINISHED"}


def default_face():
    bpy.ops.wm.read_homefile(use_empty=True)
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    rig = bpy.context.active_object
    _speak(rig)
    return rig, module("operators.face.objects").EXPORT_ROLES


def _head_obj(folder: Path) -> Path:
    data = np.load(HEAD)
    path = folder / "makehuman_neutral.obj"
    with open(path, "w") as handle:
        handle.writelines(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in data["vertices"])
        handle.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in data["faces"])
    return path


def fitted_face(folder: Path, applied: bool):
    """The MakeHuman head (Y up, decimetres) imported from OBJ (turned 90 degrees by the importer), scaled to
    metres on the object, with that transform applied first or not, fitted and speaking."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.wm.obj_import(filepath=str(_head_obj(folder)))
    head = bpy.context.selected_objects[0]
    head.scale = (0.1, 0.1, 0.1)
    head.data.shade_smooth()                       # as an artist's head would be: smooth, a skin material
    skin = bpy.data.materials.new("Skin")
    skin.diffuse_color, skin.metallic, skin.roughness = (0.8, 0.6, 0.5, 1.0), 0.0, 0.6
    head.data.materials.append(skin)
    bpy.context.view_layer.objects.active = head
    if applied:
        bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    assert bpy.ops.faces_hands.fit_face_rig() == {"FINISHED"}
    rig = module("operators.adapters.rig_store").rig_of(bpy.context.active_object) or head
    _speak(rig)
    return rig, module("operators.face.objects").EXPORT_ROLES


def hand():
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.context.scene.render.fps = FPS
    assert bpy.ops.faces_hands.build_hand_rig() == {"FINISHED"}
    obj = bpy.context.active_object
    assert bpy.ops.faces_hands.animate_hand(motion="wave_to_fist") == {"FINISHED"}
    assert bpy.ops.faces_hands.bake_hand() == {"FINISHED"}
    return obj, module("operators.hand.objects").EXPORT_ROLES


def morph_face():
    bpy.ops.wm.read_homefile(use_empty=True)
    assert bpy.ops.faces_hands.morph_new_face() == {"FINISHED"}
    bpy.context.scene.frame_start = bpy.context.scene.frame_end = 1
    return bpy.context.active_object, ()


def transform(obj, how: str) -> None:
    """The artist moves the rig: ``turned`` (rotated, scaled unevenly, moved), ``parented`` (that, under an
    Empty that moves over the take), ``centimetres`` (that, in a scene whose unit is the centimetre)."""
    if how == "as built":
        return
    obj.rotation_euler = (obj.rotation_euler[0] + 0.4, -0.3, 1.1)
    obj.scale = tuple(s * f for s, f in zip(obj.scale, (1.2, 0.9, 1.0)))
    obj.location = (0.3, -0.2, 1.4)
    if how in ("parented", "centimetres"):
        scene = bpy.context.scene
        empty = bpy.data.objects.new("Stage", None)
        scene.collection.objects.link(empty)
        empty.rotation_euler, empty.scale = (0.0, 0.2, -0.5), (1.5, 1.5, 1.5)
        for frame, where in ((scene.frame_start, (0.0, 0.0, 0.0)), (scene.frame_end, (0.4, 0.1, -0.2))):
            empty.location = where
            empty.keyframe_insert("location", frame=frame)
        world = obj.matrix_world.copy()
        obj.parent = empty
        obj.matrix_world = world
    if how == "centimetres":
        bpy.context.scene.unit_settings.scale_length = 0.01
    bpy.context.view_layer.update()


# -------------------------------------------------------------------------------------- measuring
def frames_of(scene) -> list[int]:
    first, last = scene.frame_start, scene.frame_end
    return sorted({first, *(int(round(first + k * (last - first) / 3)) for k in (1, 2, 3))})


def browser_positions(path: Path, times: np.ndarray) -> dict[str, np.ndarray]:
    """Node name -> (times, vertices, 3) world positions three.js plays (Blender axes, metres)."""
    glb = client.Glb(path)
    nodes = {n["mesh"]: n.get("name", str(k)) for k, n in enumerate(glb.gltf["nodes"]) if "mesh" in n}
    skin = SimpleNamespace(mesh=min(nodes), rest=lambda vertices: np.zeros((1, 3)))
    played = client.play(path, skin, None, times, np.zeros(0, int), [], influences=False, all_meshes=True)
    out: dict[str, list] = {}
    for entry in played["samples"]["meshes"]:
        points = np.array(entry["positions"]).reshape(len(times), -1, 3)
        out.setdefault(nodes[entry["mesh"]], []).append(np.stack([points[..., 0], -points[..., 2],
                                                                   points[..., 1]], axis=-1))
    return {name: np.concatenate(parts, axis=1) for name, parts in out.items()}


def shoot(path: Path, centre: np.ndarray, size: float, time_s: float, png: Path) -> None:
    """three.js's picture of the GLB at ``time_s``: front, side (the character's left) and back, around
    ``centre`` (Blender axes) at a distance that frames ``size`` metres; made to be looked at."""
    target = [float(centre[0]), float(centre[2]), float(-centre[1])]         # Blender Z-up -> glTF Y-up
    distance = 2.2 * size
    views = [{"yaw": yaw, "pitch": 0.0, "target": target, "distance": distance, "fov": 30}
             for yaw in (0.0, math.pi / 2, math.pi)]
    skin = SimpleNamespace(mesh=0, rest=lambda vertices: np.zeros((1, 3)))
    client.play(path, skin, None, np.array([0.0]), np.zeros(0, int), [], influences=False,
                views_shots=[{"time": time_s, "png": str(png), "views": views}], size=(1800, 600))


def measure(name: str, obj, roles, folder: Path, picture: bool = False) -> dict:
    """Export ``obj`` as GLB and FBX, read both back with Blender and the GLB with three.js: the largest
    vertex error of any part (mm) per reader."""
    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    frames = frames_of(scene)
    objects = module("operators.adapters.export").export_objects(obj, roles)
    wanted, names = checks.world_vertices(bpy, objects, frames), checks.mesh_names(objects)
    paths = {}
    for fmt in ("glb", "fbx"):
        paths[fmt] = folder / f"{name.replace(' ', '_').replace(',', '')}.{fmt}"
        module("operators.adapters.export").export_rig(bpy.context, obj, str(paths[fmt]), roles)
    result = {}
    for fmt, path in paths.items():
        imported = checks.reimport(bpy, path, fps)
        errors = checks.placement_errors(wanted, checks.world_vertices(bpy, imported, [f - frames[0] for f in frames],
                                                                       names))
        result[fmt] = {part: e * 1000 for part, e in errors.items()}
    times = (np.array(frames) - frames[0]) / fps
    played = browser_positions(paths["glb"], times)
    if picture:
        shown = min(2, len(times) - 1)                            # the second animated frame (a still: its only)
        every = np.concatenate([w[shown] for w in wanted.values()])
        shoot(paths["glb"], 0.5 * (every.min(0) + every.max(0)), float(np.ptp(every, axis=0).max()), times[shown],
              OUT / f"{name.replace(' ', '_').replace(',', '')}.png")
    result["three.js"] = {part: 1000 * checks.trajectory_error(wanted[part], played[part]) if part in played
                          else float("inf") for part in wanted}
    return result


# -------------------------------------------------------------------------------------- formats read back
def take_formats(blend: Path, name: str, folder: Path) -> dict:
    """The take of the rig ``name`` saved in ``blend``, written in every format and read back (frames and
    largest weight difference)."""
    import json

    from faces_hands_addon.anim.retarget import read_live_link_csv, take_rate
    from faces_hands_addon.speech.cues import cues_text, read_cues
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    rig = bpy.data.objects[name]
    targets, scene = module("operators.adapters.targets"), bpy.context.scene
    frames, weights = targets.animated_weights(rig, scene)
    out = {"take_frames": len(frames)}
    csv = Path(targets.write_live_link(rig, scene, str(folder / "take.csv")))
    times, back = read_live_link_csv(csv)
    out["csv_frames"], out["csv_fps"] = len(times), take_rate(times)
    out["csv_max_diff"] = max(float(np.abs(back[n] - np.clip(weights[n], 0, 1)).max()) for n in back if n in weights)
    document = json.loads(rig.get(module("operators.speech.apply").CUES_PROPERTY))
    cues = [SimpleNamespace(start=c["start"], end=c["end"], shape=c["value"]) for c in document["mouthCues"]]
    same = True
    for fmt in ("tsv", "json"):
        path = folder / f"take.{fmt}"
        path.write_text(cues_text(cues, fmt, "take.wav", document["metadata"]["duration"]))
        same &= [(c.start, c.end, c.shape) for c in read_cues(path)] == [(round(c.start, 2), round(c.end, 2), c.shape)
                                                                      for c in cues]
    out["cues_read_back"] = int(same)
    services = module("operators.face.services")
    avatar = folder / "avatar.blend"
    for fmt in ("glb", "fbx"):
        path = services.export(bpy.context, rig, str(folder / f"take.{fmt}"))
        if not avatar.exists():
            from faces_hands_addon.anim.retarget import ARKIT_NAMES
            checks.save_avatar(bpy, avatar, ARKIT_NAMES)
        played = folder / f"played_{fmt}.blend"
        services.retarget(SimpleNamespace(source=str(path), character=str(avatar), fps=None, csv_fps=None, rig=None,
                                          object=None), played)
        got_frames, got = checks.played_weights(bpy, played)
        out[f"{fmt}_take_frames"] = len(got_frames)
        out[f"{fmt}_take_max_diff"] = max(float(np.abs(got[n] - weights[n]).max()) for n in got if n in weights)
        bpy.ops.wm.open_mainfile(filepath=str(blend))
        rig = bpy.data.objects[name]
    return out


def hand_fbx(folder: Path) -> dict:
    obj, roles = hand()
    path = module("operators.adapters.export").export_rig(bpy.context, obj, str(folder / "hand_formats.fbx"), roles)
    imported = checks.reimport(bpy, path, FPS)
    armature = next((o for o in imported if o.type == "ARMATURE"), None)
    skin = next(o for o in imported if o.type == "MESH")
    keyed = 0
    if armature is not None and armature.animation_data and armature.animation_data.action:
        bag = module("operators.adapters.fcurves").existing_channelbag(armature)
        keyed = len({c.data_path.split('"')[1] for c in bag.fcurves if c.data_path.startswith("pose.bones")})
    return {"hand_fbx_bones": len(armature.data.bones) if armature else 0,
            "hand_fbx_groups": len(skin.vertex_groups), "hand_fbx_keyed_bones": keyed,
            "hand_fbx_shape_keys": len(skin.data.shape_keys.key_blocks) - 1 if skin.data.shape_keys else 0}


def set_is_absolute() -> float:
    from faces_hands_addon.morph import editing, population
    face = editing.EditFace(population.default_model())
    face.create("random", seed=11)
    face.set_attribute_value("masculine-feminine", 0.0)
    return abs(face.value("masculine-feminine"))


# --------------------------------------------------------------------------------------------- main
def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="leave out the fitted heads")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="fh-roundtrip-") as tmp:      # the exports: ~0.7 GB, not kept
        return _run(args, Path(tmp), started)


def _run(args, folder: Path, started: float) -> int:
    rigs = {"default face": default_face, "hand": hand, "morph face": morph_face}
    if not args.quick:
        rigs["fitted head, OBJ turned"] = lambda: fitted_face(folder, applied=False)
        rigs["fitted head, applied"] = lambda: fitted_face(folder, applied=True)
    table, formats, face = {}, {}, None
    for rig, build in rigs.items():
        obj, roles = build()
        saved = folder / "rig.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(saved), copy=True)
        name = obj.name
        if rig == "default face":
            face = (folder / "face.blend", name)
            bpy.ops.wm.save_as_mainfile(filepath=str(face[0]), copy=True)
        for how in ("as built", "turned", "parented", "centimetres"):
            bpy.ops.wm.open_mainfile(filepath=str(saved))
            obj = bpy.data.objects[name]
            transform(obj, how)
            table[f"{rig}, {how}"] = measure(f"{rig} {how}", obj, roles, folder, picture=how == "turned")
            worst = {reader: max(parts.values()) for reader, parts in table[f"{rig}, {how}"].items()}
            print(f"{rig + ', ' + how:42s} " + "  ".join(f"{r} {w:.4f} mm" for r, w in worst.items()), flush=True)
    formats.update(take_formats(*face, folder))
    formats.update(hand_fbx(folder))
    formats["set_error"] = set_is_absolute()
    for key, value in formats.items():
        print(f"  {key}: {value}")
    worst = {reader: max(max(parts.values()) for case in table.values() for r, parts in case.items() if r == reader)
             for reader in ("glb", "fbx", "three.js")}
    worst_case = max(table, key=lambda case: max(max(p.values()) for p in table[case].values()))
    read_back = (formats["csv_frames"] == formats["take_frames"] == formats["glb_take_frames"] ==
                 formats["fbx_take_frames"] and formats["csv_max_diff"] < 1e-5 and formats["glb_take_max_diff"] < 1e-5
                 and formats["fbx_take_max_diff"] < 1e-5 and formats["cues_read_back"] and formats["hand_fbx_bones"] > 0
                 and formats["hand_fbx_groups"] > 0 and formats["set_error"] < 1e-9)
    in_place = max(worst.values()) <= LIMIT_MM
    print(f"RESULT cases={len(table)} glb_max_mm={worst['glb']:.4f} fbx_max_mm={worst['fbx']:.4f} "
          f"threejs_max_mm={worst['three.js']:.4f} worst_case=\"{worst_case}\" take_frames={formats['take_frames']} "
          f"csv_frames={formats['csv_frames']} csv_fps={formats['csv_fps']:g} glb_take_frames={formats['glb_take_frames']} "
          f"fbx_take_frames={formats['fbx_take_frames']} take_max_diff={max(formats['glb_take_max_diff'], formats['fbx_take_max_diff']):.1e} "
          f"csv_max_diff={formats['csv_max_diff']:.1e} cues_read_back={formats['cues_read_back']} "
          f"hand_fbx_bones={formats['hand_fbx_bones']} hand_fbx_groups={formats['hand_fbx_groups']} "
          f"hand_fbx_keyed_bones={formats['hand_fbx_keyed_bones']} set_error={formats['set_error']:.1e} "
          f"in_place={int(in_place)} read_back={int(bool(read_back))} wall_s={time.perf_counter() - started:.0f}")
    return 0 if in_place and read_back else 1


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
