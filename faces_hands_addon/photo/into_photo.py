# SPDX-License-Identifier: GPL-3.0-or-later
"""A head made from a photo, posed by its face rig, rendered back into that photo (thesis 3.2.5): the rig's
skin and parts (eyes, teeth, tongue) at a pose, drawn with the photo's camera and illumination over the
original (:mod:`.composite`).

The eyeballs take their colours from the photo itself: each eyeball vertex the camera sees through the lid
opening gets the photo's albedo there (so an unmoved eye shows the photo's eye, and a turned one carries its
iris along); the rest take the photo's iris colour (iris and pupil) or its sclera colour, measured inside the
eye contours. Teeth and tongue have fixed colours.
"""
from __future__ import annotations

import numpy as np

from ..core import geometry
from .appearance import Lighting, sample_image, srgb_to_linear
from .composite import Part, composite, render_head
from .raster import rasterize

__all__ = ["part_colours", "label_colours", "posed_parts", "render_pose", "still", "PhotoProjector",
           "FIXED_COLOURS"]

FIXED_COLOURS = {"tooth": (0.62, 0.58, 0.50), "gum": (0.42, 0.12, 0.12), "tongue": (0.40, 0.10, 0.10)}


def _eye_colours(pixels_linear: np.ndarray, landmarks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(iris, sclera) linear colours measured in the photo: the iris halfway between each iris centre and its
    ring points, the sclera halfway between each iris centre and the eye corners."""
    iris = np.vstack([0.5 * (landmarks[start, :2] + landmarks[start + 1:start + 5, :2]) for start in (468, 473)])
    iris_colour = np.median(sample_image(pixels_linear, iris), axis=0)
    corners = landmarks[[33, 133, 362, 263], :2]
    centres = landmarks[[468, 468, 473, 473], :2]
    sclera = np.median(sample_image(pixels_linear, 0.5 * (corners + centres)), axis=0)
    return iris_colour, sclera


def label_colours(result, pixels_linear: np.ndarray) -> dict:
    """name -> per-vertex linear colours (n, 3) of the rig's parts by their materials (module docstring)."""
    iris, sclera = _eye_colours(pixels_linear, result.landmarks[0])
    out = {}
    for name, part in result.rig.part_meshes().items():
        labels = np.asarray(part.labels)[np.asarray(part.face_material, np.int64)]
        colours = np.zeros((len(part.vertices), 3))
        for label in set(labels.tolist()):
            corner_ids = np.unique(part.faces[labels == label])
            if label == "sclera":
                colours[corner_ids] = sclera
            elif label in ("iris", "pupil"):
                colours[corner_ids] = iris * (0.5 if label == "pupil" else 1.0)
            else:
                colours[corner_ids] = FIXED_COLOURS.get(label, (0.5, 0.5, 0.5))
        out[name] = colours
    return out


def part_colours(result, pixels_linear: np.ndarray, skin_vertices: np.ndarray, skin_triangles: np.ndarray):
    """name -> per-vertex linear colours (n, 3) of the rig's parts at rest, the eyes' from the photo where it
    sees them (module docstring; the colours the Blender objects get)."""
    camera = result.shape.cameras[0]
    lighting = result.appearance[0].lighting
    out = label_colours(result, pixels_linear)
    for name, part in result.rig.part_meshes().items():
        colours = out[name]
        if name.startswith("eye"):
            colours = _seen_from_photo(part.vertices, part.faces, colours, camera, lighting, pixels_linear,
                                       skin_vertices, skin_triangles)
        out[name] = colours
    return out


def _seen_from_photo(vertices, faces, colours, camera, lighting: Lighting, pixels_linear, skin_vertices,
                     skin_triangles):
    """Colours of the eyeball vertices the camera sees (nearest at their pixel among skin and eyeball,
    facing it) replaced by the photo's albedo there."""
    all_vertices = np.vstack([skin_vertices, vertices])
    all_faces = np.vstack([skin_triangles, faces + len(skin_vertices)])
    pixels, depth = camera.project(vertices)
    every, every_depth = camera.project(all_vertices)
    lo = np.floor(pixels.min(axis=0)).astype(int) - 2
    hi = np.ceil(pixels.max(axis=0)).astype(int) + 3
    raster = rasterize(every, all_faces, camera.width, camera.height, every_depth, (lo[0], lo[1], hi[0], hi[1]))
    ix = np.clip(np.floor(pixels[:, 0]).astype(int) - raster.origin[0], 0, max(raster.depth.shape[1] - 1, 0))
    iy = np.clip(np.floor(pixels[:, 1]).astype(int) - raster.origin[1], 0, max(raster.depth.shape[0] - 1, 0))
    normals = geometry.vertex_normals(vertices, faces) @ camera.rotation.T
    rays = camera.to_camera(vertices)
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    facing = -(normals * rays).sum(axis=1)
    if not raster.depth.size:
        return colours
    seen = (depth <= raster.depth[iy, ix] * 1.002 + 1e-5) & (facing > 0.1)
    if seen.any():
        shade = np.maximum(lighting.shading(normals[seen]), 0.05)
        colours = colours.copy()
        colours[seen] = np.clip(sample_image(pixels_linear, pixels[seen]) / shade, 0.0, 1.0)
    return colours


def posed_parts(result, colours: dict, transforms: dict | None = None) -> list[Part]:
    """The rig's parts as :class:`.composite.Part`, each moved by its 4x4 transform (mesh coordinates), with
    its rest vertices for the photo's projector."""
    out = []
    for name, part in result.rig.part_meshes().items():
        rest = np.asarray(part.vertices, np.float64)
        vertices = rest
        if transforms is not None and name in transforms:
            m = np.asarray(transforms[name], np.float64)
            vertices = rest @ m[:3, :3].T + m[:3, 3]
        out.append(Part(vertices, np.asarray(part.faces, np.int64), colours[name], rest))
    return out


class PhotoProjector:
    """The photo as a projector from its own camera, at the rest pose (thesis 3.2.5: what the photo shows is
    kept where the head has not moved): a rest point the camera saw (nearest at its pixel among the rest
    skin and parts) takes the photo's albedo there; the mouth's gaps at rest keep the photo's pixels."""

    def __init__(self, result, pixels_linear: np.ndarray, skin: np.ndarray, parts: list[Part]):
        self.camera = result.shape.cameras[0]
        self.lighting = result.appearance[0].lighting
        self.pixels = pixels_linear
        meshes = [(skin, result.mesh.triangles)] + [(p.rest, p.triangles) for p in parts]
        offsets = np.cumsum([0] + [len(v) for v, _ in meshes])
        vertices = np.vstack([v for v, _ in meshes])
        faces = np.vstack([t + o for (_, t), o in zip(meshes, offsets)])
        pixels, depth = self.camera.project(vertices)
        lo = np.floor(pixels[:offsets[1]].min(axis=0)).astype(int) - 4
        hi = np.ceil(pixels[:offsets[1]].max(axis=0)).astype(int) + 5
        self.raster = rasterize(pixels, faces, self.camera.width, self.camera.height, depth,
                                (lo[0], lo[1], hi[0], hi[1]))
        head = np.zeros_like(self.raster.mask)
        head[self.raster.mask] = self.raster.triangle[self.raster.mask] < len(result.mesh.triangles)
        from scipy import ndimage
        self.rest_gaps = ndimage.binary_fill_holes(head) & ~self.raster.mask

    def _cells(self, pixels: np.ndarray):
        ix = np.floor(pixels[:, 0]).astype(int) - self.raster.origin[0]
        iy = np.floor(pixels[:, 1]).astype(int) - self.raster.origin[1]
        h, w = self.raster.depth.shape
        inside = (ix >= 0) & (iy >= 0) & (ix < w) & (iy < h)
        return np.clip(ix, 0, max(w - 1, 0)), np.clip(iy, 0, max(h - 1, 0)), inside

    def __call__(self, points: np.ndarray, normals: np.ndarray):
        pixels, depth = self.camera.project(points)
        ix, iy, inside = self._cells(pixels)
        seen = inside & (depth <= self.raster.depth[iy, ix] * 1.003 + 1e-5)
        cam_normals = normals @ self.camera.rotation.T
        rays = self.camera.to_camera(points)
        cam_normals *= np.where((cam_normals * rays).sum(axis=1) > 0, -1.0, 1.0)[:, None]
        shade = np.maximum(self.lighting.shading(cam_normals), 0.05)
        return np.clip(sample_image(self.pixels, pixels) / shade, 0.0, 1.0), seen

    def gaps(self, pixels: np.ndarray):
        """Colours for the mouth's gaps now: the photo where the rest pose had a gap too, else the cavity."""
        ix, iy, inside = self._cells(pixels)
        was_gap = inside & self.rest_gaps[iy, ix]
        from .composite import CAVITY
        out = np.tile(CAVITY * 0.8, (len(pixels), 1))
        out[was_gap] = sample_image(self.pixels, pixels[was_gap])
        return out


def render_pose(result, pixels_srgb: np.ndarray, texture_linear: np.ndarray, skin: np.ndarray, parts: list[Part],
                projector: PhotoProjector | None = None, feather: float | None = None) -> np.ndarray:
    """The composite (H, W, 3) sRGB of the head with ``skin`` (N, 3) rig-mesh vertices and ``parts``."""
    camera = result.shape.cameras[0]
    rendering = render_head(skin, result.mesh.triangles, result.mesh.uvs, texture_linear, camera,
                            result.appearance[0].lighting, parts, projector=projector,
                            gap_colour=None if projector is None else projector.gaps)
    if feather is None:
        inter_ocular = float(np.linalg.norm(result.landmarks[0][468, :2] - result.landmarks[0][473, :2]))
        feather = max(2.0, 0.12 * inter_ocular)
    return composite(pixels_srgb, rendering, feather)


def still(result, pixels_srgb: np.ndarray) -> np.ndarray:
    """The head at rest rendered into its photo."""
    linear = srgb_to_linear(pixels_srgb)
    skin = result.mesh.vertices(result.vertices)
    parts = posed_parts(result, label_colours(result, linear))
    return render_pose(result, pixels_srgb, srgb_to_linear(result.texture.srgb), skin, parts,
                       PhotoProjector(result, linear, skin, parts))
