# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender adapters: engine data into Blender and the artist's Blender data into engine objects, for every
subsystem (nothing here imports a subsystem package; no operator classes):

``rig_store``   engine rigs stored on Blender objects, by rig kind; rig objects and their parts
``controls``    control layers as animatable properties, layer sampling, mixing drivers
``takes``       a take kept on a rig object, and the take a bake starts from
``poses``       a rig's pose into Blender (simulation shape key, part transforms)
``shape_keys``  baked shapes -> shape keys (driven basis, per-frame animation, weights)
``fcurves``     engine tracks -> F-curves in layered actions
``meshes``      engine arrays <-> meshes
``materials``   materials with shader nodes on every Blender version
``export``      glTF/FBX export of a set of objects
``render``      headless Workbench renders and PNG files
``targets``     weight animations onto characters (retarget), Live Link CSV
``blendfile``   opening and saving .blend files
``outputs``     all-or-nothing output files, the ledger of written files, no output over an input
``timing``      the scene's frame rate, seconds <-> frames
``paths``       the extension's user folder, preferences, preset overrides, the shape cache
"""
