# SPDX-License-Identifier: GPL-3.0-or-later
"""Run by :mod:`.foreign_import` in a child Blender (the ``bpy`` module, or Blender in the background): import
one foreign file with Blender's own importer into an empty scene and write what it made to a .blend.

``<python or blender ...> import_child.py -- SOURCE SUFFIX OUT.blend``: prints one JSON line, the names of
the objects written and the frame rate the imported keys count in. It imports nothing from the extension: the parent checked the file's header and sizes
and names the memory limit this process sets itself before the importer runs (``FH_IMPORT_MEMORY``); an
importer that fails leaves this process with a non-zero exit.
"""
import json
import os
import sys

MEMORY_VARIABLE = "FH_IMPORT_MEMORY"


def _import(bpy, source: str, suffix: str) -> None:
    if suffix == ".obj":
        bpy.ops.wm.obj_import(filepath=source)
    elif suffix == ".ply":
        bpy.ops.wm.ply_import(filepath=source)
    elif suffix == ".stl":
        bpy.ops.wm.stl_import(filepath=source)
    elif suffix in (".glb", ".gltf"):
        bpy.ops.import_scene.gltf(filepath=source)
    elif suffix == ".fbx":
        bpy.ops.import_scene.fbx(filepath=source)
    else:
        raise SystemExit(f"no importer for {suffix}")


def _limit_memory() -> None:
    """The data limit the parent asks for (``FH_IMPORT_MEMORY``, bytes), set before Blender's importer runs
    (and, in the bpy module, before Blender itself loads); POSIX only."""
    limit = int(os.environ.get(MEMORY_VARIABLE, "0") or 0)
    if limit > 0:
        try:
            import resource  # noqa: PLC0415 - POSIX only
        except ImportError:
            return
        resource.setrlimit(resource.RLIMIT_DATA, (limit, limit))


def main(argv) -> None:
    source, suffix, out = argv[argv.index("--") + 1:][:3]
    _limit_memory()
    import bpy  # noqa: PLC0415 - Blender or the bpy module, loaded only in the child
    bpy.ops.wm.read_factory_settings(use_empty=True)
    before = set(bpy.data.objects)
    _import(bpy, source, suffix)
    made = [o for o in bpy.data.objects if o not in before]
    bpy.data.libraries.write(out, set(made), fake_user=True)
    scene = bpy.context.scene                           # an FBX sets the frame rate its keys count in
    sys.stdout.write("FH-IMPORTED " + json.dumps({"objects": [o.name for o in made],
                                                  "fps": scene.render.fps / scene.render.fps_base}) + "\n")
    sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv)
