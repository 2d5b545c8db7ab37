# SPDX-License-Identifier: GPL-3.0-or-later
"""Tussock: capture grass blades with a depth camera, grow meadows of millions of blades,
grow Weber-Penn trees that sway in wind, and bring pictures of vegetation to life."""

bl_info = {
    "name": "Tussock",
    "author": "Tussock developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > Tussock",
    "description": "Capture, grow and animate grass and trees that move",
    "category": "Object",
}

from . import bake, handlers, prefs, ui  # noqa: E402
from .capture import operators as capture_operators  # noqa: E402
from .capture import props as capture_props  # noqa: E402
from .capture import ui as capture_ui  # noqa: E402
from .farm import submit as farm_submit  # noqa: E402
from .meadow import colliders as meadow_colliders  # noqa: E402
from .meadow import operators as meadow_operators  # noqa: E402
from .meadow import props as meadow_props  # noqa: E402
from .meadow import simulate as meadow_simulate  # noqa: E402
from .meadow import ui as meadow_ui  # noqa: E402
from .picture import animate as picture_animate  # noqa: E402
from .picture import operators as picture_operators  # noqa: E402
from .picture import props as picture_props  # noqa: E402
from .picture import ui as picture_ui  # noqa: E402
from .refine import operators as refine_operators  # noqa: E402
from .refine import ui as refine_ui  # noqa: E402
from .trees import animate as tree_animate  # noqa: E402
from .trees import operators as tree_operators  # noqa: E402
from .trees import props as tree_props  # noqa: E402
from .trees import ui as tree_ui  # noqa: E402
from .wind import operators as wind_operators  # noqa: E402
from .wind import props as wind_props  # noqa: E402
from .wind import ui as wind_ui  # noqa: E402

# One list of classes, registered in order and unregistered in reverse.
_MODULES = (prefs, ui, capture_props, capture_operators, capture_ui, meadow_props,
            meadow_colliders, meadow_operators, meadow_ui, meadow_simulate, refine_operators,
            refine_ui, wind_props, wind_operators, wind_ui, tree_props, tree_operators, tree_ui,
            tree_animate, picture_props, picture_operators, picture_ui, picture_animate, bake,
            farm_submit)


def _classes():
    for module in _MODULES:
        yield from module.classes


def register():
    import bpy

    for cls in _classes():
        bpy.utils.register_class(cls)
    for module in _MODULES:
        if hasattr(module, "register_extra"):
            module.register_extra()
    # meadows whose models changed while the add-on was disabled (Blender's data cannot be
    # read inside register: on a timer, right after it)
    meadow_simulate.rebuild_stale_models()


def unregister():
    import bpy

    handlers.remove_all()
    for module in reversed(_MODULES):
        if hasattr(module, "unregister_extra"):
            module.unregister_extra()
    for cls in reversed(list(_classes())):
        bpy.utils.unregister_class(cls)
