# SPDX-License-Identifier: GPL-3.0-or-later
"""Synthetic photographs with known truth for ``bench/photo.py``: heads the morphable model was not built from
(the MakeHuman and SOMA test heads of tests/data/heads, and scaled copies), painted with a skin texture and
rendered in Blender (EEVEE) at a known camera, head pose and lighting.

The texture is painted in a frontal planar projection: skin with seeded noise, lips, brows and eyes (sclera,
iris, pupil) drawn around the head's own 468 landmarks, which the project's mesh fitter locates on it
(``fitting.locate_landmarks``); they place the paint and define the head's frame for the pose truth, never
the shape truth, which is the mesh itself."""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix
from scipy import ndimage

HEADS = Path(__file__).resolve().parents[1] / "tests" / "data" / "heads"
#: name -> (file, units to metres, non-uniform scale of the copy (x, y, z in our frame), skin tone 0..1)
VARIANTS = {
    "mh_neutral": ("makehuman_neutral", 0.1, (1.0, 1.0, 1.0), 0.75),
    "mh_african_female_old": ("makehuman_african_female_old", 0.1, (1.0, 1.0, 1.0), 0.25),
    "soma": ("soma", 1.0, (1.0, 1.0, 1.0), 0.55),
    "mh_neutral_narrow": ("makehuman_neutral", 0.1, (0.93, 1.02, 1.05), 0.6),
    "soma_wide": ("soma", 1.0, (1.07, 0.97, 0.96), 0.85),
}
TEXTURE = 2048
SIZE = (768, 1024)


@dataclass
class ViewSpec:
    head: str
    yaw: float
    pitch: float
    roll: float
    focal_35mm: float
    sun_azimuth: float
    sun_elevation: float
    sun_strength: float
    ambient: float
    face_height: float          # fraction of the picture's height the face spans

    def key(self) -> str:
        return hashlib.sha256(json.dumps(asdict(self), sort_keys=True).encode()).hexdigest()[:16]


def view_specs(count: int, seed: int, heads: tuple[str, ...]) -> list[ViewSpec]:
    rng = np.random.default_rng(seed)
    out = []
    for index in range(count):
        yaw = 0.0 if index % 5 == 0 else float(rng.uniform(-35, 35))
        out.append(ViewSpec(heads[index % len(heads)], round(yaw, 2), round(float(rng.uniform(-12, 12)), 2),
                            round(float(rng.uniform(-8, 8)), 2), float(rng.choice([35.0, 50.0, 85.0, 135.0])),
                            round(float(rng.uniform(-70, 70)), 2), round(float(rng.uniform(10, 50)), 2),
                            round(float(rng.uniform(2.5, 4.5)), 2), round(float(rng.uniform(0.25, 0.6)), 3),
                            round(float(rng.uniform(0.35, 0.55)), 3)))
    return out


def _our_frame(vertices: np.ndarray, units: float, scale) -> np.ndarray:
    """Y up / face +Z (the test heads) -> Z up / face -Y, metres, scaled copy."""
    v = np.asarray(vertices, np.float64) * units
    return np.column_stack([v[:, 0], -v[:, 2], v[:, 1]]) * np.asarray(scale)


def prepare_head(name: str, cache: Path) -> dict:
    """Vertices (metres, our frame), faces, the head's 468 landmarks and its painted texture (cached)."""
    file, units, scale, tone = VARIANTS[name]
    data = np.load(HEADS / f"{file}.npz")
    vertices = _our_frame(data["vertices"], units, scale)
    faces = data["faces"].astype(np.int64)
    stored = cache / f"head_{name}.npz"
    if stored.exists():
        saved = np.load(stored)
        return {"name": name, "vertices": vertices, "faces": faces, "landmarks": saved["landmarks"],
                "texture": saved["texture"], "bounds": saved["bounds"], "tone": tone}
    from faces_hands_addon.fitting import locate_landmarks
    landmarks = locate_landmarks(vertices, faces, seed=0).positions
    bounds = np.array([vertices[:, 0].min(), vertices[:, 2].min(), vertices[:, 0].max(), vertices[:, 2].max()])
    texture = paint_texture(landmarks, bounds, tone, seed=sum(map(ord, name)))
    np.savez_compressed(stored, landmarks=landmarks, texture=texture, bounds=bounds)
    return {"name": name, "vertices": vertices, "faces": faces, "landmarks": landmarks, "texture": texture,
            "bounds": bounds, "tone": tone}


def _to_texel(points: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    x0, z0, x1, z1 = bounds
    side = max(x1 - x0, z1 - z0)
    return np.column_stack([(points[:, 0] - x0) / side * TEXTURE, (z0 + side - points[:, 2]) / side * TEXTURE])


def _polygon_mask(polygon: np.ndarray) -> np.ndarray:
    from faces_hands_addon.fitting.testdata import inside_polygon
    lo = np.floor(polygon.min(axis=0)).astype(int)
    hi = np.ceil(polygon.max(axis=0)).astype(int) + 1
    ys, xs = np.mgrid[lo[1]:hi[1], lo[0]:hi[0]]
    inside = inside_polygon(np.column_stack([xs.ravel() + 0.5, ys.ravel() + 0.5]), polygon).reshape(xs.shape)
    mask = np.zeros((TEXTURE, TEXTURE), bool)
    mask[lo[1]:hi[1], lo[0]:hi[0]] = inside
    return mask


def paint_texture(landmarks: np.ndarray, bounds: np.ndarray, tone: float, seed: int) -> np.ndarray:
    """(T, T, 3) linear albedo in the frontal projection (module docstring)."""
    from faces_hands_addon.assets import face_contours
    lines = face_contours().lines
    rng = np.random.default_rng(seed)
    light, dark = np.array([0.62, 0.42, 0.33]), np.array([0.13, 0.07, 0.045])
    skin = dark + tone * (light - dark)
    noise = ndimage.gaussian_filter(rng.standard_normal((TEXTURE, TEXTURE)), 3.0)
    noise = noise / noise.std() * 0.035 + ndimage.gaussian_filter(rng.standard_normal((TEXTURE, TEXTURE)), 25) * 0.6
    image = skin[None, None, :] * (1.0 + noise[..., None])
    t = lambda ids: _to_texel(landmarks[np.asarray(ids)], bounds)      # noqa: E731
    lips = np.concatenate([lines["lips_outer_upper"], lines["lips_outer_lower"][::-1]])
    lip_mask = ndimage.gaussian_filter(_polygon_mask(t(lips)).astype(float), 2.0)
    image += lip_mask[..., None] * (skin * np.array([0.85, 0.45, 0.45]) - image)
    for side in ("L", "R"):
        brow = np.concatenate([lines[f"eyebrow_{side}_upper"], lines[f"eyebrow_{side}_lower"][::-1]])
        brow_mask = ndimage.gaussian_filter(_polygon_mask(t(brow)).astype(float), 3.0)
        image += 0.85 * brow_mask[..., None] * (np.array([0.05, 0.035, 0.025]) - image)
        eye = t(lines[f"eye_{side}"])
        eye_mask = ndimage.gaussian_filter(_polygon_mask(eye).astype(float), 1.2)
        image += eye_mask[..., None] * (np.array([0.75, 0.72, 0.70]) - image)
        centre = eye.mean(axis=0)
        width = np.linalg.norm(t(lines[f"eye_{side}"][[0]]) - t(lines[f"eye_{side}"][[8]]))
        ys, xs = np.mgrid[0:TEXTURE, 0:TEXTURE]
        radius = np.hypot(xs + 0.5 - centre[0], ys + 0.5 - centre[1])
        iris = np.clip((0.21 * width - radius) / 1.5, 0, 1) * eye_mask
        pupil = np.clip((0.09 * width - radius) / 1.0, 0, 1) * eye_mask
        image += iris[..., None] * (np.array([0.12, 0.07, 0.035]) - image)
        image += pupil[..., None] * (np.array([0.01, 0.01, 0.01]) - image)
        lash = ndimage.gaussian_filter(_polyline_mask(t(lines[f"eye_{side}_upper"])).astype(float), 1.0)
        image += 0.8 * np.clip(lash * 3, 0, 1)[..., None] * (np.array([0.02, 0.015, 0.01]) - image)
    return np.clip(image, 0.0, 1.0).astype(np.float32)


def _polyline_mask(points: np.ndarray, width: float = 2.5) -> np.ndarray:
    mask = np.zeros((TEXTURE, TEXTURE), bool)
    for a, b in zip(points[:-1], points[1:]):
        steps = int(np.linalg.norm(b - a)) + 2
        for p in np.linspace(a, b, steps):
            x, y = int(p[0]), int(p[1])
            r = int(width)
            mask[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1] = True
    return mask


def head_frame(landmarks: np.ndarray, model_mean_landmarks: np.ndarray) -> np.ndarray:
    """The rotation from the model's frame to the head's own (a similarity of the model's mean landmarks onto
    the head's): the head 'facing the camera' means this frame faces it."""
    a = model_mean_landmarks - model_mean_landmarks.mean(axis=0)
    b = landmarks - landmarks.mean(axis=0)
    u, _, vt = np.linalg.svd(b.T @ a)
    d = np.eye(3)
    d[2, 2] = np.sign(np.linalg.det(u @ vt))
    return u @ d @ vt


def _euler(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """Head rotation in our frame: yaw about Z (up), pitch about X (left), roll about Y (forward)."""
    def axis(k, deg):
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        i, j = [(1, 2), (2, 0), (0, 1)][k]
        r = np.eye(3)
        r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
        return r
    return axis(2, yaw) @ axis(0, pitch) @ axis(1, roll)


def render_view(spec: ViewSpec, head: dict, frame: np.ndarray, out_png: Path) -> dict:
    """Render ``spec`` into ``out_png``; returns the truth: the head's world vertices, the camera (CV frame)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    turn = _euler(spec.yaw, spec.pitch, spec.roll) @ frame.T        # head frame faces -Y, then turned
    centre = head["landmarks"].mean(axis=0)
    world = (head["vertices"] - centre) @ turn.T
    mesh = bpy.data.meshes.new("GT Head")
    mesh.from_pydata(world.tolist(), [], head["faces"].tolist())
    uv = _to_texel(head["vertices"], head["bounds"]) / TEXTURE
    layer = mesh.uv_layers.new(name="UVMap")
    corners = uv[head["faces"].ravel()]
    layer.data.foreach_set("uv", np.column_stack([corners[:, 0], 1.0 - corners[:, 1]]).astype(np.float32).ravel())
    mesh.polygons.foreach_set("use_smooth", np.ones(len(head["faces"]), bool))
    mesh.update()
    obj = bpy.data.objects.new("GT Head", mesh)
    scene.collection.objects.link(obj)
    image = bpy.data.images.new("GT Skin", TEXTURE, TEXTURE, float_buffer=True)
    image.colorspace_settings.name = "Linear Rec.709"
    rgba = np.ones((TEXTURE, TEXTURE, 4), np.float32)
    rgba[..., :3] = head["texture"]
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    image.pack()
    material = bpy.data.materials.new("GT Skin")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = image
    bsdf = nodes["Principled BSDF"]
    material.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.55
    mesh.materials.append(material)
    w, h = SIZE
    diag = math.hypot(w, h)
    focal_px = spec.focal_35mm * diag / math.hypot(36, 24)
    face_height = float(np.ptp(world[:, 2])) * 0.62
    distance = focal_px * face_height / (spec.face_height * h)
    cam_data = bpy.data.cameras.new("GT Camera")
    cam_data.sensor_fit = "AUTO"
    cam_data.sensor_width = 36.0
    cam_data.lens = focal_px * 36.0 / max(w, h)
    cam_data.clip_start, cam_data.clip_end = 0.01, 50.0
    cam = bpy.data.objects.new("GT Camera", cam_data)
    scene.collection.objects.link(cam)
    position = np.array([0.0, -distance, 0.0])
    # a Blender camera looking along +Y (towards the face): local X -> world X, local Y -> world Z,
    # local Z -> world -Y (it looks along its local -Z)
    m = np.eye(4)
    m[:3, :3] = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    m[:3, 3] = position
    cam.matrix_world = Matrix(m.tolist())
    scene.camera = cam
    sun = bpy.data.lights.new("GT Sun", "SUN")
    sun.energy = spec.sun_strength
    sun_obj = bpy.data.objects.new("GT Sun", sun)
    az, el = math.radians(spec.sun_azimuth), math.radians(spec.sun_elevation)
    direction = np.array([math.sin(az) * math.cos(el), -math.cos(az) * math.cos(el), math.sin(el)])
    sun_obj.rotation_euler = Matrix(_look_from(direction).tolist()).to_euler()
    scene.collection.objects.link(sun_obj)
    world_data = bpy.data.worlds.new("GT World")
    world_data.use_nodes = True
    world_data.node_tree.nodes["Background"].inputs["Color"].default_value = (0.35, 0.38, 0.42, 1.0)
    world_data.node_tree.nodes["Background"].inputs["Strength"].default_value = spec.ambient
    scene.world = world_data
    scene.render.engine = "BLENDER_EEVEE"
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "Standard"
    scene.eevee.taa_render_samples = 8
    scene.render.filepath = str(out_png)
    bpy.ops.render.render(write_still=True)
    # truth in the photo's camera frame (x right, y down, z forward): world X -> x, world -Z -> y, world Y -> z
    world_to_cv = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    return {"spec": asdict(spec), "focal_px": focal_px, "size": [w, h],
            "model_to_camera": (world_to_cv @ turn @ frame).tolist(),
            "head_rotation": (world_to_cv @ turn).tolist(), "centre": centre.tolist(),
            "translation": (world_to_cv @ -position).tolist()}


def _look_from(direction: np.ndarray) -> np.ndarray:
    """A rotation whose local -Z points along -direction (a sun shining from ``direction``)."""
    z = direction / np.linalg.norm(direction)
    up = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.95 else np.array([0.0, 1.0, 0.0])
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])
