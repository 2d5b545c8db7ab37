"""The Tree panel in the Tussock sidebar tab."""

import bpy

from .. import compat
from ..ui import SubPanel


class TUSSOCK_MT_tree_presets(bpy.types.Menu):
    bl_label = "Tree Presets"
    bl_idname = "TUSSOCK_MT_tree_presets"

    def draw(self, context):
        self.layout.operator_menu_enum("tussock.tree_apply_preset", "preset", text="Apply")
        self.layout.operator("tussock.tree_preset_add", icon="ADD")
        self.layout.operator_menu_enum("tussock.tree_preset_remove", "preset", text="Remove")


def _draw_group(layout, group):
    col = layout.column(align=True)
    for name in group.__annotations__:
        if not name.startswith("level_"):
            col.prop(group, name)


class TUSSOCK_PT_tree(SubPanel, bpy.types.Panel):
    bl_label = "Tree"
    bl_idname = "TUSSOCK_PT_tree"

    def draw(self, context):
        layout = self.layout
        layout.operator_menu_enum("tussock.add_tree", "preset", text="Add Tree", icon="OUTLINER_OB_FORCE_FIELD")
        obj = context.active_object
        s = compat.settings_of(obj, "tussock_tree")
        if s is None or not s.is_tree:
            return
        if s.last_error:
            box = layout.box()
            box.alert = True
            box.label(text=s.last_error, icon="ERROR")
        layout.label(text=f"{obj.get('tussock_branches', 0):,} branches, "
                          f"{obj.get('tussock_leaves', 0):,} leaves")
        layout.menu("TUSSOCK_MT_tree_presets")
        row = layout.row(align=True)
        row.prop(s, "seed")
        row.prop(s, "leaves", toggle=True)
        layout.prop(s, "smooth_levels")
        layout.prop(s, "wind_strength")
        if hasattr(s, "params"):
            box = layout.box()
            box.label(text="Weber-Penn parameters")
            _draw_group(box, s.params)
            for i in range(4):
                sub = layout.box()
                sub.label(text=f"Level {i}")
                _draw_group(sub, getattr(s.params, f"level_{i}"))


classes = (TUSSOCK_MT_tree_presets, TUSSOCK_PT_tree)
