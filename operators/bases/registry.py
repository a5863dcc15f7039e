# SPDX-License-Identifier: GPL-3.0-or-later
"""The one place where the extension registers things with Blender, and forgets them again.

Everything goes through :func:`register_all`, which records what it did, so :func:`unregister_all`
removes exactly that, in reverse order: classes, ``PointerProperty`` attachments, menu entries, app
handlers, timers and the command-line command. Enable -> disable -> enable therefore leaves nothing stale.

Tooltips: an operator, panel or menu without ``bl_description`` gets the first paragraph of its docstring
as one line (Blender would show the docstring's line breaks and indentation).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import bpy

IDNAME_PREFIX = "faces_hands."


@dataclass
class _Registered:
    classes: list = field(default_factory=list)
    properties: list = field(default_factory=list)  # (owner type, attribute name)
    handlers: list = field(default_factory=list)    # (handler list name, function)
    timers: list = field(default_factory=list)
    cli_handles: list = field(default_factory=list)
    menus: list = field(default_factory=list)       # (menu type, draw function)
    cleanups: list = field(default_factory=list)    # functions called at unregister (e.g. free previews)


_done = _Registered()


def _check_idname(cls) -> None:
    idname = getattr(cls, "bl_idname", "")
    if issubclass(cls, bpy.types.Operator) and not idname.startswith(IDNAME_PREFIX):
        raise ValueError(f"{cls.__name__}.bl_idname {idname!r} must start with {IDNAME_PREFIX!r}")


def one_line(text: str | None) -> str:
    """The first paragraph of ``text`` on one line (whitespace collapsed)."""
    paragraph = (text or "").strip().split("\n\n")[0]
    return " ".join(paragraph.split())


def _describe(cls) -> None:
    own = cls.__dict__.get("bl_description")
    if own is None and issubclass(cls, (bpy.types.Operator, bpy.types.Panel, bpy.types.Menu)) and cls.__doc__:
        cls.bl_description = one_line(cls.__doc__)
    elif own is not None and "\n" in own:
        cls.bl_description = one_line(own)


def register_all(classes, properties=(), handlers=(), cli_commands=(), menus=(), cleanups=()) -> None:
    """Register ``classes`` (in order), then attach ``properties`` = [(owner, name, property)], then
    append ``menus`` = [(menu type name, draw function)], ``handlers`` = [(handler list name, function)] and
    ``cli_commands`` = [(name, fn)]; ``cleanups`` are called at unregister (resources made on demand, such
    as icon previews)."""
    _done.cleanups.extend(cleanups)
    for cls in classes:
        _check_idname(cls)
        _describe(cls)
        bpy.utils.register_class(cls)
        _done.classes.append(cls)
    for owner, name, prop in properties:
        setattr(owner, name, prop)
        _done.properties.append((owner, name))
    for menu_name, draw in menus:
        getattr(bpy.types, menu_name).append(draw)
        _done.menus.append((menu_name, draw))
    for list_name, function in handlers:
        getattr(bpy.app.handlers, list_name).append(function)
        _done.handlers.append((list_name, function))
    for name, function in cli_commands:
        _done.cli_handles.append(bpy.utils.register_cli_command(name, function))


def add_timer(function: Callable[[], float | None], first_interval: float = 0.0) -> None:
    """Start a timer that :func:`unregister_all` is sure to stop."""
    bpy.app.timers.register(function, first_interval=first_interval)
    _done.timers.append(function)


def remove_timer(function) -> None:
    if bpy.app.timers.is_registered(function):
        bpy.app.timers.unregister(function)
    if function in _done.timers:
        _done.timers.remove(function)


def unregister_all() -> None:
    for function in reversed(_done.cleanups):
        function()
    for handle in reversed(_done.cli_handles):
        bpy.utils.unregister_cli_command(handle)
    for function in reversed(_done.timers):
        if bpy.app.timers.is_registered(function):
            bpy.app.timers.unregister(function)
    for list_name, function in reversed(_done.handlers):
        handler_list = getattr(bpy.app.handlers, list_name)
        if function in handler_list:
            handler_list.remove(function)
    for menu_name, draw in reversed(_done.menus):
        menu = getattr(bpy.types, menu_name, None)
        if menu is not None:
            menu.remove(draw)
    for owner, name in reversed(_done.properties):
        if hasattr(owner, name):
            delattr(owner, name)
    for cls in reversed(_done.classes):
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)
    _done.__init__()


def registered_summary() -> dict:
    """What is registered now (for tests and the info command)."""
    return {
        "classes": [c.__name__ for c in _done.classes],
        "properties": [f"{o.__name__}.{n}" for o, n in _done.properties],
        "handlers": [f"{n}:{f.__name__}" for n, f in _done.handlers],
        "timers": [f.__name__ for f in _done.timers],
        "cli": len(_done.cli_handles),
        "menus": [f"{n}:{f.__name__}" for n, f in _done.menus],
    }
