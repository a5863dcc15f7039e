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

from ...faces_hands_addon.anim.layers import weighted_driver
from ..adapters import controls
from ..adapters.materials import enable_nodes

#: region -> (wave direction in object space, furrow spacing in metres, bump strength at full contraction)
PATTERNS = {"forehead": ("Z", 0.03, 1.4), "brow_furrow": ("X", 0.014, 0.8), "nose_bridge": ("Z", 0.01, 0.5)}


def _wave_scale(spacing: float) -> float:
    """Blender's band wave has period 2 pi / (10 * scale) in texture space."""
    return 2.0 * 3.141592653589793 / (10.0 * spacing)


def _mask_attribute(mesh, region: str, weights: np.ndarray) -> str:
    name = f"fh_wrinkle_{region}"
    attribute = mesh.attributes.get(name) or mesh.attributes.new(name, "FLOAT", "POINT")
    attribute.data.foreach_set("value", np.asarray(weights, dtype=np.float32))
    return name


def _strength_driver(socket, obj, drivers, specs) -> None:
    """Driver: the wrinkle strength rule of the engine (``anim.layers.weighted_sum`` of mixed controls)."""
    terms = [(muscle, weight) for muscle, weight in drivers if muscle in specs]
    expression = weighted_driver(terms, specs, available=controls.available_layers(obj, [m for m, _ in terms]))
    controls.add_mixed_driver(socket, "default_value", obj, expression)


def setup_wrinkle_material(obj, masks: dict[str, np.ndarray], drivers_by_region: dict, specs: dict
                           ) -> bpy.types.Material:
    """Give ``obj`` its own skin material with driven wrinkle bumps (replacing slot 0's material).

    One Bump node per region, chained through their Normal inputs: Height is the furrow pattern (smooth,
    so no triangle edges show), Strength is mask attribute x driven strength, so a relaxed muscle or a
    vertex outside the region leaves the normal untouched."""
    base = obj.data.materials[0] if obj.data.materials else None
    mat = base.copy() if base is not None else bpy.data.materials.new(f"{obj.name} Skin")
    mat.name = f"{obj.name} Skin"
    enable_nodes(mat)
    if obj.data.materials:
        obj.data.materials[0] = mat
    else:
        obj.data.materials.append(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes.get("Principled BSDF")
    coords = nodes.new("ShaderNodeTexCoord")
    coords.location = (-1300, 0)
    previous_normal = None
    for row, (region, weights) in enumerate(masks.items()):
        if region not in drivers_by_region:
            continue
        axis, spacing, depth = PATTERNS.get(region, ("Z", 0.006, 0.8))
        y = -320 * row
        attribute = nodes.new("ShaderNodeAttribute")
        attribute.attribute_name = _mask_attribute(obj.data, region, weights)
        attribute.location = (-1000, y)
        wave = nodes.new("ShaderNodeTexWave")
        wave.wave_type = "BANDS"
        wave.bands_direction = axis
        wave.inputs["Scale"].default_value = _wave_scale(spacing)
        wave.inputs["Distortion"].default_value = 0.0
        wave.location = (-1000, y - 160)
        links.new(coords.outputs["Object"], wave.inputs["Vector"])
        strength = nodes.new("ShaderNodeValue")
        strength.label = f"wrinkles {region}"
        strength.name = f"FH wrinkle {region}"
        strength.location = (-800, y + 80)
        _strength_driver(strength.outputs[0], obj, drivers_by_region[region], specs)
        weighted = nodes.new("ShaderNodeMath")
        weighted.operation = "MULTIPLY"
        weighted.location = (-600, y)
        links.new(attribute.outputs["Fac"], weighted.inputs[0])
        links.new(strength.outputs[0], weighted.inputs[1])
        scaled = nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        scaled.inputs[1].default_value = depth
        scaled.location = (-450, y)
        links.new(weighted.outputs[0], scaled.inputs[0])
        bump = nodes.new("ShaderNodeBump")
        bump.name = f"FH wrinkle bump {region}"
        bump.location = (-250, y)
        bump.inputs["Distance"].default_value = 0.0008
        links.new(scaled.outputs[0], bump.inputs["Strength"])
        links.new(wave.outputs["Fac"], bump.inputs["Height"])
        if previous_normal is not None:
            links.new(previous_normal, bump.inputs["Normal"])
        previous_normal = bump.outputs["Normal"]
    if previous_normal is not None and bsdf is not None:
        links.new(previous_normal, bsdf.inputs["Normal"])
    return mat
