# SPDX-License-Identifier: GPL-3.0-or-later
"""Expressive wrinkles (thesis 3.1.2, Fig. 3.5): a bump map on the skin whose strength per region is
driven by the contraction of the muscles that cause it.

MEDUSA drew a "wrinkle height field" with GeForce register combiners; here the skin material gets,
per region, a procedural furrow pattern (horizontal on the forehead, vertical between the brows) masked
by a per-vertex weight attribute and scaled by a driver on the rig's control properties, all summed into
one Bump node. Works in EEVEE and Cycles; the glTF/FBX export ignores it (it is shading, not geometry).
"""
from __future__ import annotations

import bpy
import numpy as np

from . import bl_controls

#: region -> (wave direction in object space, bands per metre, depth)
PATTERNS = {"forehead": ("Z", 160.0, 1.0), "brow_furrow": ("X", 260.0, 1.0), "nose_bridge": ("Z", 300.0, 0.6)}


def _mask_attribute(mesh, region: str, weights: np.ndarray) -> str:
    name = f"fh_wrinkle_{region}"
    attribute = mesh.attributes.get(name) or mesh.attributes.new(name, "FLOAT", "POINT")
    attribute.data.foreach_set("value", np.asarray(weights, dtype=np.float32))
    return name


def _strength_driver(socket, obj, drivers) -> None:
    """Driver: min(1, sum of weight * contraction) over all control layers."""
    fcurve = socket.driver_add("default_value")
    driver = fcurve.driver
    driver.type = "SCRIPTED"
    terms = []
    index = 0
    for muscle, weight in drivers:
        for layer in bl_controls.LAYERS:
            prop = bl_controls.prop_name(muscle, layer)
            if prop not in obj.keys():
                continue
            var = driver.variables.new()
            var.name = f"v{index}"
            var.type = "SINGLE_PROP"
            var.targets[0].id_type = "OBJECT"
            var.targets[0].id = obj
            var.targets[0].data_path = f'["{prop}"]'
            terms.append(f"{weight:.3f}*v{index}")
            index += 1
    driver.expression = f"min(1.0, {' + '.join(terms) or '0.0'})"


def setup_wrinkle_material(obj, masks: dict[str, np.ndarray], drivers_by_region: dict) -> bpy.types.Material:
    """Give ``obj`` its own skin material with driven wrinkle bumps (replacing slot 0's material)."""
    base = obj.data.materials[0] if obj.data.materials else None
    mat = base.copy() if base is not None else bpy.data.materials.new(f"{obj.name} Skin")
    mat.name = f"{obj.name} Skin"
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    if obj.data.materials:
        obj.data.materials[0] = mat
    else:
        obj.data.materials.append(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes.get("Principled BSDF")
    coords = nodes.new("ShaderNodeTexCoord")
    total = None
    for row, (region, weights) in enumerate(masks.items()):
        if region not in drivers_by_region:
            continue
        axis, bands, depth = PATTERNS.get(region, ("Z", 200.0, 1.0))
        attribute = nodes.new("ShaderNodeAttribute")
        attribute.attribute_name = _mask_attribute(obj.data, region, weights)
        attribute.location = (-900, -300 * row)
        wave = nodes.new("ShaderNodeTexWave")
        wave.wave_type = "BANDS"
        wave.bands_direction = axis
        wave.inputs["Scale"].default_value = bands * 0.1
        wave.location = (-900, -300 * row - 150)
        links.new(coords.outputs["Object"], wave.inputs["Vector"])
        strength = nodes.new("ShaderNodeValue")
        strength.label = f"wrinkles {region}"
        strength.name = f"FH wrinkle {region}"
        strength.location = (-700, -300 * row - 100)
        _strength_driver(strength.outputs[0], obj, drivers_by_region[region])
        masked = nodes.new("ShaderNodeMath")
        masked.operation = "MULTIPLY"
        links.new(attribute.outputs["Fac"], masked.inputs[0])
        links.new(wave.outputs["Fac"], masked.inputs[1])
        scaled = nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        links.new(masked.outputs[0], scaled.inputs[0])
        links.new(strength.outputs[0], scaled.inputs[1])
        if depth != 1.0:
            scaled_depth = nodes.new("ShaderNodeMath")
            scaled_depth.operation = "MULTIPLY"
            scaled_depth.inputs[1].default_value = depth
            links.new(scaled.outputs[0], scaled_depth.inputs[0])
            scaled = scaled_depth
        if total is None:
            total = scaled
        else:
            adder = nodes.new("ShaderNodeMath")
            adder.operation = "ADD"
            links.new(total.outputs[0], adder.inputs[0])
            links.new(scaled.outputs[0], adder.inputs[1])
            total = adder
    if total is not None and bsdf is not None:
        bump = nodes.new("ShaderNodeBump")
        bump.name = "FH wrinkle bump"
        bump.inputs["Strength"].default_value = 0.6
        bump.inputs["Distance"].default_value = 0.0015
        links.new(total.outputs[0], bump.inputs["Height"])
        links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    return mat
