"""The Tussock tab in the 3D viewport sidebar. Feature panels are children of this one."""

import bpy

from . import native


class TUSSOCK_PT_main(bpy.types.Panel):
    bl_label = "Tussock"
    bl_idname = "TUSSOCK_PT_main"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Tussock"

    def draw(self, context):
        layout = self.layout
        if not native.available():
            box = layout.box()
            box.alert = True
            box.label(text="Native library missing", icon="ERROR")
            # the full message, wrapped over a few lines
            words, line = native.error.split(), ""
            for word in words:
                if len(line) + len(word) > 40:
                    box.label(text=line)
                    line = ""
                line += word + " "
            if line:
                box.label(text=line)
            return
        layout.label(text=f"Tussock {native.version()}")


class SubPanel:
    """Where every feature panel sits: under the Tussock tab's main panel."""
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Tussock"
    bl_parent_id = "TUSSOCK_PT_main"


class TUSSOCK_MT_add(bpy.types.Menu):
    """Tussock's objects in the 3D viewport's Add menu (Shift+A), where every other object is
    added: the same operators as the sidebar buttons, with their redo panels."""
    bl_idname = "TUSSOCK_MT_add"
    bl_label = "Tussock"

    def draw(self, context):
        layout = self.layout
        layout.operator_context = "INVOKE_REGION_WIN"
        layout.operator("tussock.add_meadow", icon="OUTLINER_OB_CURVES")
        layout.operator("tussock.add_tree", icon="OUTLINER_OB_MESH")
        layout.operator("tussock.add_wind_source", icon="FORCE_WIND")


def _draw_add_menu(self, context):
    self.layout.menu(TUSSOCK_MT_add.bl_idname, icon="OUTLINER_OB_CURVES")


classes = (TUSSOCK_PT_main, TUSSOCK_MT_add)


def register_extra():
    bpy.types.VIEW3D_MT_add.append(_draw_add_menu)


def unregister_extra():
    bpy.types.VIEW3D_MT_add.remove(_draw_add_menu)
