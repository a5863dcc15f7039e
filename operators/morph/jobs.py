# SPDX-License-Identifier: GPL-3.0-or-later
"""The morphable faces' long work as jobs (``bases.jobs``): build a model from meshes (5.1.10) and hand a
face to the face-rig builder. Each computes in ``step`` and writes Blender data only in ``commit``."""
from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ..bases.jobs import Job
from ..adapters.meshes import mesh_triangles, mesh_vertices
from . import services

__all__ = ["BuildModelJob", "MakeAnimatableJob", "examples_from_objects"]


def examples_from_objects(objects) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Names, world-space vertices (N, n, 3) and triangles of mesh objects that share one topology."""
    meshes = sorted((o for o in objects if o.type == "MESH" and not o.get(services.MORPH_MARKER)),
                    key=lambda o: o.name)
    if len(meshes) < 3:
        raise UserError(f"select at least 3 example meshes of one topology (selected: {len(meshes)})")
    first = mesh_triangles(meshes[0].data)
    names, shapes = [], []
    for obj in meshes:
        triangles = mesh_triangles(obj.data)
        if len(obj.data.vertices) != len(meshes[0].data.vertices) or not np.array_equal(triangles, first):
            raise UserError(f"'{obj.name}' has another topology than '{meshes[0].name}' "
                            f"({len(obj.data.vertices)} vertices, {len(triangles)} triangles, against "
                            f"{len(meshes[0].data.vertices)} and {len(first)}); a morphable model needs meshes "
                            "in correspondence")
        matrix = np.asarray(obj.matrix_world, np.float64)
        shapes.append(mesh_vertices(obj.data).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3])
        names.append(obj.name)
    return names, np.array(shapes), first.astype(np.int64)


class BuildModelJob(Job):
    label = "Building morphable model"

    def __init__(self, context, folder: str, labels: str, out: str):
        from ..adapters.outputs import check_output_path
        self.out = check_output_path(bpy.path.abspath(out), (".npz",))
        if folder:
            from ...faces_hands_addon.morph.meshfiles import read_example_folder
            self.names, self.shapes, self.triangles = read_example_folder(bpy.path.abspath(folder))
        else:
            self.names, self.shapes, self.triangles = examples_from_objects(context.selected_objects)
        self.labels_path = Path(bpy.path.abspath(labels)) if labels else None
        if self.labels_path is not None and not self.labels_path.is_file():
            raise UserError(f"labels file {self.labels_path} does not exist")
        if self.labels_path is not None and self.labels_path.resolve() == self.out.resolve():
            raise UserError("the model must not overwrite the labels file")
        self.model = None

    def step(self) -> float:
        from ...faces_hands_addon.morph.build import build_model, read_labels_csv
        labels, rows = ({}, None)
        if self.labels_path is not None:
            labels, rows = read_labels_csv(self.labels_path, self.names)
        self.model = build_model(self.out.stem, self.shapes, self.triangles, labels=labels,
                                 example_names=self.names, example_labels=rows,
                                 segments={"face": np.ones(self.shapes.shape[1], bool)},
                                 info={"source": "built from meshes", "examples": len(self.names)})
        return 1.0

    def commit(self, context) -> str:
        from ...faces_hands_addon.morph.model import save_model
        from ..adapters.outputs import atomic_output
        with atomic_output(self.out) as tmp:
            save_model(self.model, tmp)
        services.remember_model(str(self.out.resolve()), self.model)
        context.scene.faces_hands_morph.model_path = str(self.out)
        return (f"Built '{self.out.name}': {len(self.names)} examples, {self.model.shape.components} components, "
                f"{len(self.model.attributes)} attributes")


class MakeAnimatableJob(Job):
    label = "Making the face animatable"

    def __init__(self, obj):
        self.name, self.obj = obj.name, obj

    def step(self) -> float:
        return 1.0

    def commit(self, context) -> str:
        rig = services.make_animatable(context, bpy.data.objects[self.name])
        for other in context.view_layer.objects.selected:
            other.select_set(False)
        rig.select_set(True)
        context.view_layer.objects.active = rig
        return f"Built face rig '{rig.name}' on the morphed face"
