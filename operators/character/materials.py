# SPDX-License-Identifier: GPL-3.0-or-later
"""The character's materials, after MPFB2's: the procedural eye built from MPFB2's own node-tree JSON
(``assets/mpfb2/node_trees/procedural_eyes.json``, with ``eye_settings.default.json``), a procedural skin with
MPFB2's default skin settings per region (``enhanced_settings.default.json``: body, lips, nails; the regions
come from MPFB2's UV masks ``textures/mpfb_*.jpg``, packed into the file; the mouth's lining darkened by its
mask), painted eyebrows, teeth and tongue.

Node-tree JSON (MPFB2's format): ``nodes`` (name -> ``type`` = node bl_idname, ``label``, ``location``,
``values`` = input defaults by socket name, optional ``value`` of a Value node, ``operation``, ``use_clamp``,
``group_name``), ``links`` (``from_node``/``from_socket`` -> ``to_node``/``to_socket``, sockets by name or
index) and ``groups`` (name -> ``inputs``/``outputs`` interface + their own nodes and links).
"""
from __future__ import annotations

import json

import bpy

from ...faces_hands_addon.character import mpfb2
from ...faces_hands_addon.character.body import MATERIALS
from ...faces_hands_addon.character.model import material_settings
from ...faces_hands_addon.core.errors import UserError
from ..adapters.materials import enable_nodes

__all__ = ["character_materials", "build_node_tree", "BROW_ATTRIBUTE"]

PREFIX = "FH Character"
NODE_ATTRIBUTES = ("operation", "use_clamp", "blend_type", "data_type", "interpolation", "distribution",
                   "subsurface_method", "feature", "voronoi_dimensions", "noise_dimensions")
SKIN_TONE = (0.62, 0.39, 0.29)            # linear RGB, a light-medium skin tone
LIP_TONE = (0.45, 0.19, 0.18)
BROW_TONE = (0.035, 0.022, 0.015)         # dark brown brow hair (the default head's, ``face.appearance``)
BROW_ATTRIBUTE = "FH Brows"               # per-vertex brow paint (``character.fitting.brow_paint``)
NAIL_TONE = (0.85, 0.66, 0.60)
MOUTH_TONE = (0.22, 0.055, 0.05)         # the mouth's lining: dark red, wet
REGION_MASKS = {"lips": "mpfb_lips.jpg", "fingernails": "mpfb_fingernails.jpg", "toenails": "mpfb_toenails.jpg",
                "inside-mouth": "mpfb_inside-mouth.jpg"}
REGION_ROUGHNESS = {"inside-mouth": 0.25}  # MPFB2's settings have no mouth region


def _socket(sockets, key):
    if isinstance(key, int):
        return sockets[key] if key < len(sockets) else None
    return sockets.get(key)


def _set_default(socket, value) -> None:
    if socket is None or not hasattr(socket, "default_value"):
        return
    try:
        if isinstance(value, list):
            current = socket.default_value
            socket.default_value = value[:len(current)] if hasattr(current, "__len__") else value[0]
        else:
            socket.default_value = value
    except (TypeError, ValueError, AttributeError):
        pass                                   # a socket this Blender version types differently


def _groups(data: dict) -> dict:
    """Build the JSON's node groups (a group used by another is built first)."""
    built: dict = {}

    def build(name: str):
        if name in built:
            return built[name]
        spec = data["groups"][name]
        tree = bpy.data.node_groups.get(f"{PREFIX} {name}")
        if tree is None:
            tree = bpy.data.node_groups.new(f"{PREFIX} {name}", "ShaderNodeTree")
            for in_out, table in (("INPUT", spec.get("inputs", {})), ("OUTPUT", spec.get("outputs", {}))):
                for socket_name, entry in table.items():
                    kind = entry["type"] if isinstance(entry, dict) else entry
                    socket = tree.interface.new_socket(socket_name, in_out=in_out, socket_type=kind)
                    if isinstance(entry, dict) and "value" in entry:
                        _set_default(socket, entry["value"])
            built[name] = tree
            _fill(tree, spec, build)
        built[name] = tree
        return tree
    for group_name in data.get("groups", {}):
        build(group_name)
    return built


def _fill(tree, spec: dict, group) -> None:
    nodes = {}
    for key, entry in spec.get("nodes", {}).items():
        if entry.get("create") is False:
            continue
        node = tree.nodes.new(entry["type"])
        node.name, node.label = key, entry.get("label", "")
        node.location = entry.get("location", (0.0, 0.0))
        if entry["type"] == "ShaderNodeGroup":
            node.node_tree = group(entry["group_name"])
        for attribute in NODE_ATTRIBUTES:
            if attribute in entry and hasattr(node, attribute):
                setattr(node, attribute, entry[attribute])
        for socket_name, value in entry.get("values", {}).items():
            _set_default(node.inputs.get(socket_name), value)
        if "value" in entry and node.outputs:
            _set_default(node.outputs[0], entry["value"])
        nodes[key] = node
    for link in spec.get("links", []):
        a, b = nodes.get(link["from_node"]), nodes.get(link["to_node"])
        if a is None or b is None:
            continue
        out, into = _socket(a.outputs, link["from_socket"]), _socket(b.inputs, link["to_socket"])
        if out is not None and into is not None:
            tree.links.new(out, into)


def build_node_tree(material, data: dict, values: dict | None = None) -> None:
    """Replace ``material``'s node tree by the MPFB2 node-tree JSON ``data``; ``values`` override the inputs
    of its group nodes (MPFB2's settings files)."""
    enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    groups = _groups(data)
    _fill(tree, data, lambda name: groups[name])
    for node in tree.nodes:
        if node.type == "GROUP":
            for key, value in (values or {}).items():
                _set_default(node.inputs.get(key), value)


def _eye(settings: dict):
    material = bpy.data.materials.new(f"{PREFIX} Eye")
    path = mpfb2.MPFB2_DIR / "node_trees" / "procedural_eyes.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise UserError(f"{path.name}: cannot read MPFB2's eye material ({error}); run `make assets`") from None
    build_node_tree(material, data, settings)
    material.diffuse_color = (0.9, 0.9, 0.9, 1.0)
    return material


def _principled(name: str, colour, roughness: float, subsurface: float = 0.0):
    material = bpy.data.materials.new(f"{PREFIX} {name}")
    enable_nodes(material)
    shader = material.node_tree.nodes.get("Principled BSDF")
    shader.inputs["Base Color"].default_value = (*colour, 1.0)
    shader.inputs["Roughness"].default_value = roughness
    if subsurface:
        shader.inputs["Subsurface Weight"].default_value = subsurface
        shader.inputs["Subsurface Radius"].default_value = (1.0, 0.35, 0.2)
        shader.inputs["Subsurface Scale"].default_value = 0.01
    material.diffuse_color = (*colour, 1.0)
    return material, shader


def _mask(tree, file_name: str, location):
    """An image texture node of an MPFB2 region mask (packed into the .blend), sampled by the UVs."""
    image = bpy.data.images.get(file_name)
    if image is None:
        image = bpy.data.images.load(str(mpfb2.MPFB2_DIR / "textures" / file_name), check_existing=True)
        image.colorspace_settings.name = "Non-Color"
        image.pack()
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image, node.location = image, location
    return node


def _skin(settings: dict):
    """Principled skin (subsurface, MPFB2's body roughness and coat) with the lips and nails regions of
    MPFB2's masks in their own colour and roughness, and the pore bump of its settings."""
    body = settings.get("body", {})
    material, shader = _principled("Skin", SKIN_TONE, float(body.get("Roughness", 0.45)), 0.15)
    shader.inputs["Coat Weight"].default_value = float(body.get("Clearcoat", 0.1))
    shader.inputs["Coat Roughness"].default_value = float(body.get("Clearcoat Roughness", 0.3))
    tree = material.node_tree
    colour, roughness = shader.inputs["Base Color"], shader.inputs["Roughness"]
    colour_out = roughness_out = None
    tones = {"lips": LIP_TONE, "fingernails": NAIL_TONE, "toenails": NAIL_TONE, "inside-mouth": MOUTH_TONE}
    for k, (region, file_name) in enumerate(REGION_MASKS.items()):
        mask = _mask(tree, file_name, (-900, 300 - 300 * k))
        mix_colour = tree.nodes.new("ShaderNodeMixRGB")
        mix_colour.location = (-500, 300 - 300 * k)
        tree.links.new(mask.outputs["Color"], mix_colour.inputs["Fac"])
        if colour_out is None:
            mix_colour.inputs["Color1"].default_value = (*SKIN_TONE, 1.0)
        else:
            tree.links.new(colour_out, mix_colour.inputs["Color1"])
        mix_colour.inputs["Color2"].default_value = (*tones[region], 1.0)
        colour_out = mix_colour.outputs["Color"]
        mix_rough = tree.nodes.new("ShaderNodeMath")
        mix_rough.operation, mix_rough.location = "MULTIPLY_ADD", (-300, 200 - 300 * k)
        region_roughness = settings.get(region, {}).get("Roughness", REGION_ROUGHNESS.get(region, 0.45))
        delta = float(region_roughness) - float(body.get("Roughness", 0.45))
        tree.links.new(mask.outputs["Color"], mix_rough.inputs[0])
        mix_rough.inputs[1].default_value = delta
        if roughness_out is None:
            mix_rough.inputs[2].default_value = float(body.get("Roughness", 0.45))
        else:
            tree.links.new(roughness_out, mix_rough.inputs[2])
        roughness_out = mix_rough.outputs["Value"]
    brows = tree.nodes.new("ShaderNodeAttribute")
    brows.attribute_name, brows.location = BROW_ATTRIBUTE, (-500, 600)
    mix_brows = tree.nodes.new("ShaderNodeMixRGB")
    mix_brows.location = (-250, 450)
    tree.links.new(brows.outputs["Fac"], mix_brows.inputs["Fac"])
    tree.links.new(colour_out, mix_brows.inputs["Color1"])
    mix_brows.inputs["Color2"].default_value = (*BROW_TONE, 1.0)
    tree.links.new(mix_brows.outputs["Color"], colour)
    tree.links.new(roughness_out, roughness)
    _pores(tree, shader, body)
    return material


def _pores(tree, shader, body: dict) -> None:
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.location = (-500, -700)
    noise.inputs["Scale"].default_value = float(body.get("Pore scale", 2500.0))
    noise.inputs["Detail"].default_value = float(body.get("Pore detail", 2.0))
    noise.inputs["Distortion"].default_value = float(body.get("Pore distortion", 1.0))
    bump = tree.nodes.new("ShaderNodeBump")
    bump.location = (-250, -700)
    bump.inputs["Strength"].default_value = 0.25 * float(body.get("Pore strength", 0.2))
    tree.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    tree.links.new(bump.outputs["Normal"], shader.inputs["Normal"])


def character_materials() -> list:
    """The materials of :data:`...faces_hands_addon.character.body.MATERIALS`, in that order."""
    settings = material_settings()
    made = {"skin": _skin(settings["skin"]), "eye": _eye(settings["eye"]),
            "teeth": _principled("Teeth", (0.86, 0.83, 0.74), 0.3, 0.05)[0],
            "tongue": _principled("Tongue", (0.62, 0.25, 0.25), 0.45, 0.1)[0]}
    return [made[name] for name in MATERIALS]
