"""Every panel and menu of the extension draws, in every kind of scene that shows it (nothing selected, a
face rig, a hand rig, a morph face), and every layout call it makes is one Blender's own ``UILayout`` takes
(``tests/ui_layout.py``: signatures introspected from the running Blender, properties and operators that
exist). A panel that no scene draws fails: its poll is never true, or it was left out here."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from conftest import addon_module
from ui_layout import CheckedLayout, LayoutError, panel_host

SCENES = {
    "nothing": lambda bpy: None,
    "face rig": lambda bpy: bpy.ops.faces_hands.build_face_rig(),
    "hand rig": lambda bpy: bpy.ops.faces_hands.build_hand_rig(),
    "morph face": lambda bpy: bpy.ops.faces_hands.morph_new_face(),
}


def _draw(bpy, cls, context) -> list:
    layout = CheckedLayout(bpy)
    host = panel_host(cls, layout)
    if hasattr(cls, "draw_header"):
        cls.draw_header(host, context)
    cls.draw(host, context)
    return layout.log


def test_every_panel_and_menu_draws_with_calls_blender_takes(bpy_clean):
    bpy = bpy_clean
    panels = addon_module("panels")
    menus = addon_module("panels.menus")
    drawn, calls = set(), 0
    for scene, build in SCENES.items():
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        build(bpy)
        context = bpy.context
        for cls in panels.CLASSES:
            if hasattr(cls, "poll") and not cls.poll(context):
                continue
            try:
                log = _draw(bpy, cls, context)
            except LayoutError as error:
                raise AssertionError(f"{cls.__name__} with {scene}: {error}") from None
            assert log, (cls.__name__, scene)
            drawn.add(cls.__name__)
            calls += len(log)
        for function in (menus.draw_add, menus.draw_object, menus.draw_export):
            layout = CheckedLayout(bpy)
            function(SimpleNamespace(layout=layout), context)
            calls += len(layout.log)
    assert drawn == {cls.__name__ for cls in panels.CLASSES}, "never drawn: " + ", ".join(
        sorted({cls.__name__ for cls in panels.CLASSES} - drawn))
    assert calls > 300


@pytest.mark.parametrize("call, message", [
    (lambda bpy, layout: layout.prop(bpy.context.scene, "no_such_property"), "no property"),
    (lambda bpy, layout: layout.operator("faces_hands.no_such_operator"), "no_such_operator"),
    (lambda bpy, layout: layout.label(txt="typo"), "no parameter 'txt'"),
    (lambda bpy, layout: layout.label(text="x", icon="NO_SUCH_ICON"), "not one of its items"),
    (lambda bpy, layout: layout.row(align="yes"), "takes a boolean"),
    (lambda bpy, layout: setattr(layout, "enable", False), "no writable attribute"),
    (lambda bpy, layout: setattr(layout.operator("wm.read_homefile"), "use_emptyy", True), "no property"),
    (lambda bpy, layout: layout.prop_enum(bpy.context.scene.render, "engine", "NO_ENGINE"), "not an item"),
])
def test_the_stand_in_refuses_what_blender_refuses(bpy_clean, call, message):
    with pytest.raises(LayoutError, match=message):
        call(bpy_clean, CheckedLayout(bpy_clean))
