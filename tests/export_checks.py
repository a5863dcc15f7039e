"""Where an exported file puts every vertex, measured against the scene that wrote it, and a take read back
through a character that plays it (tests and bench).

The scene side is Blender's evaluated meshes (shape keys, armature skinning, modifiers, object and parent
transforms) in world space at chosen frames. The file side is the same file re-imported by Blender's own glTF
or FBX importer into an empty scene with the same frame rate (or played by three.js, ``bench/roundtrip.py``),
evaluated at the same moments of the clip. Vertices correspond through their whole trajectory (nearest
neighbour over the positions at every sampled frame together): exporters split vertices at seams and sealed
lips coincide at rest, so a correspondence from one frame alone would be ambiguous.
"""
from __future__ import annotations

import numpy as np

FBX_ANIM_OFFSET = 0.0      # import FBX keys at the frames they were exported at (the importer's default is 1)


def mesh_names(objects) -> dict[str, str]:
    """Mesh data name -> object name of the mesh objects among ``objects`` (for :func:`world_vertices`)."""
    return {o.data.name: o.name for o in objects if o.type == "MESH"}


def world_vertices(bpy, objects, frames, names: dict[str, str] | None = None) -> dict[str, np.ndarray]:
    """Name -> (frames, vertices, 3) world positions in metres (the scene's unit scale applied) of each mesh
    object among ``objects``, evaluated at each of ``frames`` (scene frames, may be fractional; ``None``
    keeps the current frame). With ``names`` (:func:`mesh_names` of the scene's objects), an object named
    like none of them is named after the scene object whose mesh it has (Blender's glTF importer names a
    skinned mesh's object after its mesh)."""
    scene = bpy.context.scene
    units = scene.unit_settings
    metres = 1.0 if units.system == "NONE" else units.scale_length
    meshes = [o for o in objects if o.type == "MESH"]
    names = names or {}
    known = set(names.values())
    label = {o: o.name if o.name in known or o.data.name not in names else names[o.data.name] for o in meshes}
    out = {label[o]: [] for o in meshes}
    current = scene.frame_current, scene.frame_subframe
    try:
        for frame in frames:
            if frame is not None:
                scene.frame_set(int(np.floor(frame)), subframe=float(frame - np.floor(frame)))
            graph = bpy.context.evaluated_depsgraph_get()
            for obj in meshes:
                evaluated = obj.evaluated_get(graph)
                mesh = evaluated.to_mesh()
                co = np.empty(3 * len(mesh.vertices))
                mesh.vertices.foreach_get("co", co)
                world = np.array(evaluated.matrix_world)
                out[label[obj]].append(metres * (co.reshape(-1, 3) @ world[:3, :3].T + world[:3, 3]))
                evaluated.to_mesh_clear()
    finally:
        scene.frame_set(current[0], subframe=current[1])
    return {name: np.stack(values) for name, values in out.items()}


def reimport(bpy, path, fps: float) -> list:
    """Empty the scene (same frame rate) and import ``path`` (.glb or .fbx) with Blender's importer; the
    imported objects."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = int(round(fps)), round(fps) / fps
    before = set(bpy.data.objects)
    if str(path).lower().endswith(".fbx"):
        bpy.ops.import_scene.fbx(filepath=str(path), anim_offset=FBX_ANIM_OFFSET)
    else:
        options = bpy.ops.import_scene.gltf.get_rna_type().properties.keys()
        extra = {"disable_bone_shape": True} if "disable_bone_shape" in options else {}   # no display mesh
        bpy.ops.import_scene.gltf(filepath=str(path), **extra)
    return [o for o in bpy.data.objects if o not in before]


def trajectory_error(scene: np.ndarray, file: np.ndarray) -> float:
    """Largest distance between a vertex of either side and its counterpart on the other, over
    every sampled frame; counterparts are nearest neighbours over the whole trajectory."""
    from scipy.spatial import cKDTree
    a = scene.transpose(1, 0, 2).reshape(scene.shape[1], -1)
    b = file.transpose(1, 0, 2).reshape(file.shape[1], -1)
    worst = 0.0
    for mine, theirs, one, other in ((a, b, scene, file), (b, a, file, scene)):
        _, index = cKDTree(theirs).query(mine)
        gap = np.linalg.norm(one - other[:, index], axis=2)
        worst = max(worst, float(gap.max()))
    return worst


def placement_errors(scene: dict[str, np.ndarray], file: dict[str, np.ndarray]) -> dict[str, float]:
    """Part name -> largest vertex error (metres) of the file against the scene; a part missing from
    either side is infinitely wrong."""
    names = set(scene) | set(file)
    return {name: trajectory_error(scene[name], file[name]) if name in scene and name in file else float("inf")
            for name in sorted(names)}


def save_avatar(bpy, path, names) -> None:
    """A .blend holding ``Avatar``: a three-vertex character with one shape key per name of ``names``, the
    character a retargeted take plays on."""
    bpy.ops.wm.read_homefile(use_empty=True)
    mesh = bpy.data.meshes.new("Avatar")
    mesh.from_pydata([(0, 0, 0.005), (0, 0, -0.005), (0.02, 0, 0)], [], [(0, 1, 2)])
    avatar = bpy.data.objects.new("Avatar", mesh)
    bpy.context.scene.collection.objects.link(avatar)
    avatar.shape_key_add(name="Basis", from_mix=False)
    for name in names:
        avatar.shape_key_add(name=name, from_mix=False).data[1].co.z -= 0.001
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


def played_weights(bpy, path) -> tuple[list[int], dict[str, np.ndarray]]:
    """The scene's frames and, per animated shape key of ``Avatar`` in the .blend ``path``, its weight at
    each frame."""
    bpy.ops.wm.open_mainfile(filepath=str(path))
    avatar, scene = bpy.data.objects["Avatar"], bpy.context.scene
    frames = list(range(scene.frame_start, scene.frame_end + 1))
    action = avatar.data.shape_keys.animation_data.action
    slot = avatar.data.shape_keys.animation_data.action_slot
    bags = [strip.channelbag(slot) for layer in action.layers for strip in layer.strips]
    curves = [c for bag in bags if bag is not None for c in bag.fcurves]
    return frames, {c.data_path.split('"')[1]: np.array([c.evaluate(f) for f in frames]) for c in curves}
