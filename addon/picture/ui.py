"""The Picture panel in the Tussock sidebar tab: the picture, its layer list, each layer's
mask and motion, and Animate Picture; separation and the shared wind in sub-panels."""

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
        layout.use_property_split = True
        layout.use_property_decorate = True
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
        layout.prop(s, "loop_frames")
        if s.applied and frames.dumps(frames.spec(s, s.filepath, s.layers)) \
                != s.applied:
            col = layout.column(align=True)
            col.label(text="Picture or masks changed:", icon="INFO")
            col.label(text="animate again", icon="BLANK1")
        layout.operator("tussock.animate_picture", icon="IMAGE_DATA")

    @staticmethod
    def _draw_layer(layout, layer):
        col = layout.column()
        col.prop(layer, "mask_mode")
        if layer.mask_mode == "FILE":
            col.prop(layer, "mask_path", text="File")
        elif layer.mask_mode == "IMAGE":
            col.prop_search(layer, "mask_image", bpy.data, "images", text="Image")
        else:
            col.prop(layer, "rect")
            col.prop(layer, "strokes_path")
            sub = layout.column(align=True)
            sub.prop(layer, "grabcut_iterations")
            sub.prop(layer, "grabcut_max_side", text="Proposal")
        layout.label(text="Motion")
        col = layout.column(align=True)
        col.prop(layer, "lambda_x")
        col.prop(layer, "lambda_y")
        col = layout.column()
        col.prop(layer, "scale_map_path")
        col.prop(layer, "rigidity")
        col.prop(layer, "root")
        if layer.root != "NONE":
            col = layout.column(heading="Root Line")
            col.prop(layer, "root_auto", text="From Mask")
            if not layer.root_auto:
                sub = col.column(align=True)
                sub.prop(layer, "root_line", text="Position")
                sub.prop(layer, "root_height")
        col = layout.column(align=True)
        col.prop(layer, "cell_x", text="Cell X")
        col.prop(layer, "cell_y", text="Y")


class TUSSOCK_PT_picture_separation(SubPanel, bpy.types.Panel):
    bl_label = "Separation"
    bl_idname = "TUSSOCK_PT_picture_separation"
    bl_parent_id = "TUSSOCK_PT_picture"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = True
        s = context.scene.tussock_picture
        layout.prop(s, "inpaint", text="Inpaint")
        col = layout.column(align=True)
        col.prop(s, "inpaint_radius")
        col.prop(s, "grow")
        col.prop(s, "feather")


class TUSSOCK_PT_picture_wind(SubPanel, bpy.types.Panel):
    bl_label = "Wind"
    bl_idname = "TUSSOCK_PT_picture_wind"
    bl_parent_id = "TUSSOCK_PT_picture"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = True
        w = context.scene.tussock_wind  # the shared wind that moves the picture
        layout.label(text="The scene's wind (shared)", icon="FORCE_WIND")
        col = layout.column()
        col.prop(w, "use_fluid", text="Fluid")
        sub = col.column(align=True)
        sub.active = w.use_fluid
        sub.prop(w, "fluid_size")
        sub.prop(w, "fluid_resolution")
        col = layout.column()
        col.active = w.use_fluid
        col.prop(w, "use_continuum", text="Continuum")
        sub = col.column(align=True)
        sub.active = w.use_continuum
        sub.prop(w, "continuum_c", text="Speed c")
        sub.prop(w, "continuum_gamma", text="Damping")


classes = (TUSSOCK_UL_picture_layers, TUSSOCK_PT_picture, TUSSOCK_PT_picture_separation,
           TUSSOCK_PT_picture_wind)
