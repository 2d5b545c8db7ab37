"""The Tree panel in the Tussock sidebar tab, with the Weber-Penn parameters in sub-panels:
the whole tree's, then one per branch level."""

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


def _tree(context):
    """The active object's tree settings, or None when it is not a tree."""
    s = compat.settings_of(context.active_object, "tussock_tree")
    return s if s is not None and s.is_tree else None


# The Weber-Penn parameters in groups, each an aligned column, with labels short enough for
# the label column at the default sidebar width (the property's own name is in its tooltip).
# A parameter the native library adds later and no group names is drawn after the groups.
TREE_GROUPS = (
    (("shape", "Shape"), ("levels", "Levels"), ("base_size", "Base Size"),
     ("base_splits", "Splits")),
    (("scale", "Scale"), ("scale_v", "Variation"), ("z_scale", "Z Scale"),
     ("z_scale_v", "Variation"), ("scale0", "Scale 0"), ("scale0_v", "Variation")),
    (("ratio", "Ratio"), ("ratio_power", "Power"), ("taper_power", "Taper"),
     ("flare", "Flare")),
    (("lobes", "Lobes"), ("lobe_depth", "Depth"), ("lobe_fade", "Fade")),
    (("bulges", "Bulges"), ("bulge_depth", "Depth")),
    (("leaves", "Leaves"), ("leaf_shape", "Shape"), ("leaf_scale", "Scale"),
     ("leaf_scale_x", "Scale X")),
    (("attraction_up", "Attraction"),),
    (("prune_ratio", "Prune"), ("prune_width", "Width"), ("prune_width_peak", "Peak")),
    (("prune_power_low", "Lower"), ("prune_power_high", "Upper")),
)
LEVEL_GROUPS = (
    (("branches", "Branches"), ("length", "Length"), ("length_v", "Variation"),
     ("taper", "Taper")),
    (("seg_splits", "Splits"), ("split_angle", "Angle"), ("split_angle_v", "Variation")),
    (("curve_res", "Segments"), ("curve", "Curve"), ("curve_back", "Back"),
     ("curve_v", "Variation")),
    (("down_angle", "Down"), ("down_angle_v", "Variation")),
    (("rotate", "Rotate"), ("rotate_v", "Variation")),
)


def _draw_groups(layout, group, groups):
    layout.use_property_split = True
    layout.use_property_decorate = True
    names = [name for name in group.__annotations__ if not name.startswith("level_")]
    for rows in groups:
        col = layout.column(align=True)
        for name, text in rows:
            if name in names:
                col.prop(group, name, text=text)
    named = {name for rows in groups for name, _ in rows}
    rest = [name for name in names if name not in named]
    if rest:
        col = layout.column(align=True)
        for name in rest:
            col.prop(group, name)


class TUSSOCK_PT_tree(SubPanel, bpy.types.Panel):
    bl_label = "Tree"
    bl_idname = "TUSSOCK_PT_tree"

    def draw(self, context):
        layout = self.layout
        layout.operator_menu_enum("tussock.add_tree", "preset", text="Add Tree",
                                  icon="OUTLINER_OB_FORCE_FIELD")
        s = _tree(context)
        if s is None:
            return
        obj = context.active_object
        if s.last_error:
            box = layout.box()
            box.alert = True
            box.label(text=s.last_error, icon="ERROR")
        layout.label(text=f"{obj.get('tussock_branches', 0):,} branches, "
                          f"{obj.get('tussock_leaves', 0):,} leaves")
        layout.menu("TUSSOCK_MT_tree_presets")
        layout.use_property_split = True
        layout.use_property_decorate = True
        col = layout.column()
        col.prop(s, "seed")
        col.prop(s, "leaves")
        col.prop(s, "smooth_levels")
        col.prop(s, "wind_strength", text="Wind")


class TreeParamsPanel(SubPanel):
    bl_parent_id = "TUSSOCK_PT_tree"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        s = _tree(context)
        return s is not None and hasattr(s, "params")


class TUSSOCK_PT_tree_params(TreeParamsPanel, bpy.types.Panel):
    bl_label = "Weber-Penn Parameters"
    bl_idname = "TUSSOCK_PT_tree_params"

    def draw(self, context):
        _draw_groups(self.layout, _tree(context).params, TREE_GROUPS)


class TreeLevelPanel(TreeParamsPanel):
    level = 0

    def draw(self, context):
        params = _tree(context).params
        _draw_groups(self.layout, getattr(params, f"level_{self.level}"), LEVEL_GROUPS)


class TUSSOCK_PT_tree_level_0(TreeLevelPanel, bpy.types.Panel):
    bl_label = "Level 0 (Trunk)"
    bl_idname = "TUSSOCK_PT_tree_level_0"
    level = 0


class TUSSOCK_PT_tree_level_1(TreeLevelPanel, bpy.types.Panel):
    bl_label = "Level 1"
    bl_idname = "TUSSOCK_PT_tree_level_1"
    level = 1


class TUSSOCK_PT_tree_level_2(TreeLevelPanel, bpy.types.Panel):
    bl_label = "Level 2"
    bl_idname = "TUSSOCK_PT_tree_level_2"
    level = 2


class TUSSOCK_PT_tree_level_3(TreeLevelPanel, bpy.types.Panel):
    bl_label = "Level 3"
    bl_idname = "TUSSOCK_PT_tree_level_3"
    level = 3


classes = (TUSSOCK_MT_tree_presets, TUSSOCK_PT_tree, TUSSOCK_PT_tree_params,
           TUSSOCK_PT_tree_level_0, TUSSOCK_PT_tree_level_1, TUSSOCK_PT_tree_level_2,
           TUSSOCK_PT_tree_level_3)
