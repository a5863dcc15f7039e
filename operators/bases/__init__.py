# SPDX-License-Identifier: GPL-3.0-or-later
"""Operator bases and jobs, for every subsystem (nothing here imports a subsystem package):

``registry``        the one place that registers and unregisters anything with Blender
``hardened``        the operator base whose ``execute`` turns errors into one clear report
``jobs``            long work as steps (no bpy), run modally by ``modal`` (progress bar, Esc) or to the end
``modal``           the modal runner of jobs
``bake``            the bake job of any rig (the engine bakes of ``anim.bakes``, committed as shape keys)
``live``            the live preview operator and tick of any rig
``file_operators``  operators that write a file the artist names (file browser, export options)
"""
