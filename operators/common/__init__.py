# SPDX-License-Identifier: GPL-3.0-or-later
"""What every subsystem's operators share (nothing here imports a subsystem package):

``registry``    the one place that registers and unregisters anything with Blender
``hardened``    the operator base whose ``execute`` turns errors into one clear report
``jobs``        long work as steps (no bpy), run modally by ``modal`` (progress bar, Esc) or to the end
``outputs``     all-or-nothing output files
``rig_store``   engine rigs stored on Blender objects, by rig kind; rig objects and their parts
``controls``    control layers as animatable properties, layer sampling, mixing drivers
``poses``       writing a rig's pose into Blender (simulation shape key, part transforms)
``shape_keys``  baked shapes -> shape keys (driven basis, per-frame animation)
``bake``        the bake job for any rig (basis, expressions, animation)
``live``        the live preview tick for any rig
``fcurves``     engine tracks -> F-curves in layered actions
``meshes``      engine arrays <-> meshes
``export``      glTF/FBX export of a set of objects
``render``      headless Workbench renders and PNG files
``blendfile``   opening and saving .blend files for the command line
``timing``      the scene's frame rate
``materials``   materials with shader nodes on every Blender version
"""
