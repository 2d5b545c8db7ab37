"""tussock.add_tree and the preset operators."""

import bpy

from .. import bounds, compat, errors, meshes, native
from . import build, params, presets, props


class TUSSOCK_OT_add_tree(bpy.types.Operator):
    """Grow a Weber-Penn tree at the 3D cursor; it sways in the scene's wind"""
    bl_idname = "tussock.add_tree"
    bl_label = "Add Tree"
    bl_options = {"REGISTER", "UNDO"}

    preset: bpy.props.EnumProperty(name="Preset", items=presets.items,
                                   description="Species preset: built-in Weber-Penn parameters or "
                                               "one of your own")
    # the stored settings' definitions, checked against their limits in _add (bounds.py)
    seed: bounds.operator_property(props.annotations["seed"])
    leaves: bounds.operator_property(props.annotations["leaves"])
    smooth_levels: bounds.operator_property(props.annotations["smooth_levels"])

    def execute(self, context):
        return errors.run(self, self._add, context)

    def _add(self, context):
        native.require()
        bounds.check_operator(self, props.TussockTreeSettings, ("seed", "smooth_levels"))
        d = presets.load(self.preset)
        obj = bpy.data.objects.new(self.preset.replace("user:", "").replace("_", " ").title(),
                                   bpy.data.meshes.new("Tree"))
        s = obj.tussock_tree
        try:
            params.from_dict(s.params, d)   # is_tree is False: no rebuild yet
            s.seed, s.leaves, s.smooth_levels = self.seed, self.leaves, self.smooth_levels
            data = build.compute(s)          # raises before the object joins the scene
        except Exception:
            mesh = obj.data
            bpy.data.objects.remove(obj)
            bpy.data.meshes.remove(mesh)
            raise
        obj.location = context.scene.cursor.location
        context.collection.objects.link(obj)
        # a new object is not evaluated yet: its own transform is where it stands
        build.write_posed(obj, data, context.scene, context.scene.frame_current,
                          obj.matrix_basis.copy(), by_operator=True)
        s.is_tree = True
        meshes.select_new(context, [obj])
        self.report({"INFO"}, f"{obj.name}: {obj['tussock_branches']:,} branches, "
                              f"{obj['tussock_leaves']:,} leaves")
        return {"FINISHED"}


class TUSSOCK_OT_tree_preset_add(bpy.types.Operator):
    """Save the active tree's parameters as a preset of your own"""
    bl_idname = "tussock.tree_preset_add"
    bl_label = "Save Tree Preset"

    name: bpy.props.StringProperty(name="Name", default="My tree")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        s = compat.settings_of(obj, "tussock_tree")
        return s is not None and s.is_tree

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        return errors.run(self, self._save, context)

    def _save(self, context):
        d = build.definition(context.active_object.tussock_tree)
        name = presets.save(self.name, d)
        self.report({"INFO"}, f"Saved tree preset '{name}'")
        return {"FINISHED"}


class TUSSOCK_OT_tree_preset_remove(bpy.types.Operator):
    """Remove one of your tree presets"""
    bl_idname = "tussock.tree_preset_remove"
    bl_label = "Remove Tree Preset"

    preset: bpy.props.EnumProperty(name="Preset", items=presets.items,
                                   description="Species preset: built-in Weber-Penn parameters or "
                                               "one of your own")

    def execute(self, context):
        return errors.run(self, self._remove)

    def _remove(self):
        presets.remove(self.preset)
        self.report({"INFO"}, f"Removed tree preset '{self.preset[5:]}'")
        return {"FINISHED"}


class TUSSOCK_OT_tree_apply_preset(bpy.types.Operator):
    """Load a preset's parameters into the active tree"""
    bl_idname = "tussock.tree_apply_preset"
    bl_label = "Apply Tree Preset"
    bl_options = {"REGISTER", "UNDO"}

    preset: bpy.props.EnumProperty(name="Preset", items=presets.items,
                                   description="Species preset: built-in Weber-Penn parameters or "
                                               "one of your own")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        s = compat.settings_of(obj, "tussock_tree")
        return s is not None and s.is_tree

    def execute(self, context):
        return errors.run(self, self._apply, context)

    def _apply(self, context):
        obj = context.active_object
        s = obj.tussock_tree
        meshes.refuse_edit_mode(obj, "applying a preset")  # before the settings change
        d = presets.load(self.preset)
        native.require().tree_create(d)  # check it before changing anything
        old = params.to_dict(s.params)
        s.is_tree = False
        params.from_dict(s.params, d)
        s.is_tree = True
        try:
            build.rebuild(obj)
        except Exception:
            # the preset is valid but the tree could not be posed (e.g. the scene's wind is
            # refused): a cancelled operator leaves the settings as they were
            s.is_tree = False
            params.from_dict(s.params, old)
            s.is_tree = True
            raise
        return {"FINISHED"}


classes = (TUSSOCK_OT_add_tree, TUSSOCK_OT_tree_preset_add, TUSSOCK_OT_tree_preset_remove,
           TUSSOCK_OT_tree_apply_preset)
