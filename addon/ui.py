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


classes = (TUSSOCK_PT_main,)
