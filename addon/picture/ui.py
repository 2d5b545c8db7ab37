"""The Picture panel in the Tussock sidebar tab: the picture, its layer list, each layer's
mask and motion, separation and loop settings, and Animate Picture."""

import bpy

from . import frames
from ..ui import SubPanel


class TUSSOCK_UL_picture_layers(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_prop, index=0):
        layout.prop(item, "name", text="", emboss=False, icon="OUTLINER_OB_FORCE_FIELD")
        layout.label(text=item.mask_mode.title())


class TUSSOCK_PT_picture(SubPanel, bpy.types.Panel):
    bl_label = "Picture"
    bl_idname = "TUSSOCK_PT_picture"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        s = context.scene.tussock_picture
        if s.last_error:
            box = layout.box()
            box.alert = True
            box.label(text=s.last_error, icon="ERROR")
        layout.prop(s, "filepath")
        layout.label(text="Layers (back to front)")
        row = layout.row()
        row.template_list("TUSSOCK_UL_picture_layers", "", s, "layers", s, "active_layer",
                          rows=3)
        col = row.column(align=True)
        col.operator("tussock.picture_layer_add", icon="ADD", text="")
        col.operator("tussock.picture_layer_remove", icon="REMOVE", text="")
        if 0 <= s.active_layer < len(s.layers):
            self._draw_layer(layout, s.layers[s.active_layer])
        box = layout.box()
        box.label(text="Separation")
        box.prop(s, "inpaint")
        row = box.row(align=True)
        row.prop(s, "inpaint_radius")
        row.prop(s, "grow")
        box.prop(s, "feather")
        layout.prop(s, "loop_frames")
        w = context.scene.tussock_wind  # the shared wind that moves the picture
        box = layout.box()
        box.label(text="Wind (shared with meadows and trees)")
        row = box.row(align=True)
        row.prop(w, "use_fluid", toggle=True)
        row.prop(w, "use_continuum", toggle=True)
        row = box.row(align=True)
        row.prop(w, "fluid_size")
        row.prop(w, "fluid_resolution")
        row = box.row(align=True)
        row.prop(w, "continuum_c")
        row.prop(w, "continuum_gamma")
        if s.applied and frames.dumps(frames.spec(s, s.filepath, s.layers)) \
                != s.applied:
            layout.label(text="Picture or masks changed: animate again", icon="INFO")
        layout.operator("tussock.animate_picture", icon="IMAGE_DATA")

    @staticmethod
    def _draw_layer(layout, layer):
        box = layout.box()
        box.prop(layer, "mask_mode")
        if layer.mask_mode == "FILE":
            box.prop(layer, "mask_path")
        elif layer.mask_mode == "IMAGE":
            box.prop_search(layer, "mask_image", bpy.data, "images")
        else:
            box.prop(layer, "rect")
            box.prop(layer, "strokes_path")
            row = box.row(align=True)
            row.prop(layer, "grabcut_iterations")
            row.prop(layer, "grabcut_max_side")
        box = layout.box()
        box.label(text="Motion")
        row = box.row(align=True)
        row.prop(layer, "lambda_x")
        row.prop(layer, "lambda_y")
        box.prop(layer, "scale_map_path")
        box.prop(layer, "rigidity")
        box.prop(layer, "root")
        if layer.root != "NONE":
            box.prop(layer, "root_auto")
            if not layer.root_auto:
                row = box.row(align=True)
                row.prop(layer, "root_line")
                row.prop(layer, "root_height")
        row = box.row(align=True)
        row.prop(layer, "cell_x")
        row.prop(layer, "cell_y")


classes = (TUSSOCK_UL_picture_layers, TUSSOCK_PT_picture)
