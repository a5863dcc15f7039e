"""A stand-in for Blender's ``UILayout`` (the bpy module draws no UI) that holds every call to the real one.

Each method a panel calls must be a function of ``bpy.types.UILayout`` (introspected from the running
Blender, so every line of Blender the tests run on checks its own API), with its parameters: positional
ones in order, keywords by name, required ones present, each of the type Blender declares (an enum value
among its items: icons included). Beyond the signature, what Blender would only show as a red "property not
found" label or an empty button fails too: ``prop``/``prop_enum``/``prop_search``/``template_*`` name an
existing property of their data (custom properties included), ``operator`` an operator that exists (and the
properties set on what it returns exist on it), ``menu``/``popover`` a registered class, ``template_list``
a registered list over an existing collection. Layout attributes (``enabled``, ``alignment``, ...) must be
``UILayout`` properties with values of their type. Every call is logged as ``(name, args, kwargs)``.
"""
from __future__ import annotations

NUMBER_TYPES = {"BOOLEAN": (bool, int), "INT": (int,), "FLOAT": (int, float), "STRING": (str,)}


class LayoutError(AssertionError):
    """A call Blender's UILayout would reject or draw as an error."""


def _enum_values(prop) -> set[str] | None:
    items = getattr(prop, "enum_items", None)
    values = {item.identifier for item in items} if items is not None else set()
    return values or None           # dynamic enums list no items here: not checked


def _check_value(where: str, prop, value) -> None:
    kind = prop.type
    if kind in NUMBER_TYPES:
        if not isinstance(value, NUMBER_TYPES[kind]):
            raise LayoutError(f"{where}: {prop.identifier} takes a {kind.lower()}, not {value!r}")
    elif kind == "ENUM":
        allowed = _enum_values(prop)
        values = value if getattr(prop, "is_enum_flag", False) else {value}
        if not isinstance(values, (set, frozenset)) or not all(isinstance(v, str) for v in values):
            raise LayoutError(f"{where}: {prop.identifier} takes an enum identifier, not {value!r}")
        if allowed is not None and not set(values) <= allowed:
            raise LayoutError(f"{where}: {prop.identifier}={value!r} is not one of its items")
    elif kind == "POINTER" and value is None and prop.is_required:
        raise LayoutError(f"{where}: {prop.identifier} is required and got None")


def _has_property(data, path: str) -> bool:
    if path.startswith('["') and path.endswith('"]'):
        return hasattr(data, "keys") and path[2:-2] in data.keys()
    rna = getattr(data, "bl_rna", None)
    return rna is not None and path in rna.properties


class OperatorProperties:
    """What ``layout.operator`` returns: setting a property that the operator lacks (or a wrong value) fails."""

    def __init__(self, bpy, idname: str):
        module, _, name = idname.partition(".")
        try:
            rna = getattr(getattr(bpy.ops, module), name).get_rna_type()
        except (KeyError, AttributeError):
            raise LayoutError(f"layout.operator: no operator {idname!r}") from None
        object.__setattr__(self, "_rna", rna)
        object.__setattr__(self, "_idname", idname)

    def __setattr__(self, name, value):
        prop = self._rna.properties.get(name)
        if prop is None or name == "rna_type":
            raise LayoutError(f"operator {self._idname} has no property {name!r}")
        _check_value(f"{self._idname}.{name}", prop, value)


class CheckedLayout:
    """The stand-in layout (module docstring); ``log`` collects every call, shared with its sub-layouts."""

    def __init__(self, bpy, log: list | None = None):
        object.__setattr__(self, "_bpy", bpy)
        object.__setattr__(self, "log", [] if log is None else log)
        object.__setattr__(self, "_values", {})

    @property
    def _rna(self):
        return self._bpy.types.UILayout.bl_rna

    def __getattr__(self, name):
        if name in self._rna.properties:
            return self._values.get(name, getattr(self._rna.properties[name], "default", None))
        function = self._rna.functions.get(name)
        if function is None:
            raise LayoutError(f"UILayout has no {name!r}")

        def call(*args, **kwargs):
            values = self._bind(function, args, kwargs)
            self._semantics(name, values)
            self.log.append((name, args, kwargs))
            outputs = [p for p in function.parameters if p.is_output]
            made = [self._output(p, values) for p in outputs]
            return None if not made else made[0] if len(made) == 1 else tuple(made)
        return call

    def __setattr__(self, name, value):
        prop = self._rna.properties.get(name)
        if prop is None or prop.is_readonly:
            raise LayoutError(f"UILayout has no writable attribute {name!r}")
        _check_value(f"layout.{name}", prop, value)
        self._values[name] = value

    def _bind(self, function, args, kwargs) -> dict:
        inputs = [p for p in function.parameters if not p.is_output]
        where = f"layout.{function.identifier}"
        if len(args) > len(inputs):
            raise LayoutError(f"{where} takes {len(inputs)} arguments, got {len(args)} positional")
        values = dict(zip((p.identifier for p in inputs), args))
        for key, value in kwargs.items():
            if key not in {p.identifier for p in inputs}:
                raise LayoutError(f"{where} has no parameter {key!r} (it has {[p.identifier for p in inputs]})")
            if key in values:
                raise LayoutError(f"{where} got {key!r} twice")
            values[key] = value
        for prop in inputs:
            if prop.is_required and prop.identifier not in values:
                raise LayoutError(f"{where} needs {prop.identifier!r}")
            if prop.identifier in values:
                _check_value(where, prop, values[prop.identifier])
        return values

    def _semantics(self, name: str, values: dict) -> None:
        bpy = self._bpy
        for data_key, path_key in (("data", "property"), ("search_data", "search_property"),
                                   ("dataptr", "propname"), ("active_dataptr", "active_propname")):
            if values.get(data_key) is not None and path_key in values and values[path_key]:
                if not _has_property(values[data_key], values[path_key]):
                    raise LayoutError(f"layout.{name}: {values[data_key]!r} has no property {values[path_key]!r}")
        if name == "prop_enum":
            prop = values["data"].bl_rna.properties[values["property"]]
            allowed = _enum_values(prop)
            if allowed is not None and values["value"] not in allowed:
                raise LayoutError(f"layout.prop_enum: {values['value']!r} is not an item of {values['property']}")
        if name in ("operator", "operator_menu_enum", "operator_enum", "operator_menu_hold"):
            OperatorProperties(bpy, values["operator"])            # raises when it does not exist
        if name == "menu" and not hasattr(bpy.types, values["menu"]):
            raise LayoutError(f"layout.menu: no menu {values['menu']!r} is registered")
        if name == "popover" and not hasattr(bpy.types, values["panel"]):
            raise LayoutError(f"layout.popover: no panel {values['panel']!r} is registered")
        if name == "template_list" and not hasattr(bpy.types, values["listtype_name"]):
            raise LayoutError(f"layout.template_list: no UIList {values['listtype_name']!r} is registered")

    def _output(self, prop, values):
        fixed = getattr(prop, "fixed_type", None)
        if fixed is not None and fixed.identifier == "OperatorProperties":
            return OperatorProperties(self._bpy, values["operator"])
        if fixed is not None and fixed.identifier == "UILayout":
            return CheckedLayout(self._bpy, self.log)
        return None


def panel_host(cls, layout):
    """What a panel's or menu's ``draw`` gets as ``self``: ``layout`` and the class's own attributes and methods
    (those the extension defines: a RigControlsPanel's ``rig_kind``, ...), bound to it."""
    import types
    host = types.SimpleNamespace(layout=layout)
    for klass in reversed(cls.__mro__):
        if not klass.__module__.startswith(cls.__module__.split(".")[0]) or klass.__module__.startswith("bpy"):
            continue
        for name, value in vars(klass).items():
            if name.startswith("__"):
                continue
            if isinstance(value, (staticmethod, classmethod)):
                value = value.__get__(host, cls)
            elif isinstance(value, types.FunctionType):
                value = types.MethodType(value, host)
            setattr(host, name, value)
    host.layout = layout
    return host
