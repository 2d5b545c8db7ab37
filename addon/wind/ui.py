"""The Wind panel in the Tussock sidebar tab: the scene's wind and the selected source."""

import bpy

from .. import compat
from ..ui import SubPanel


class TUSSOCK_PT_wind(SubPanel, bpy.types.Panel):
    bl_label = "Wind"
    bl_idname = "TUSSOCK_PT_wind"

    def draw(self, context):
        layout = self.layout
        w = context.scene.tussock_wind
        row = layout.row(align=True)
        row.prop(w, "base_speed")
        row.prop(w, "base_direction")
        for i, wave in enumerate(w.waves):
            box = layout.box()
            head = box.row()
            head.label(text=f"Wave {i + 1}")
            head.operator("tussock.wind_wave_remove", text="", icon="X").index = i
            col = box.column(align=True)
            for name in ("amplitude", "direction", "wavelength", "speed", "phase", "power"):
                col.prop(wave, name)
        layout.operator("tussock.wind_wave_add", icon="ADD")
        col = layout.column(align=True)
        col.prop(w, "gust_strength")
        col.prop(w, "gust_interval")
        col.prop(w, "gust_duration")
        col.prop(w, "gust_front_speed")
        col.prop(w, "seed")
        layout.prop(w, "use_fluid")
        if w.use_fluid:
            col = layout.column(align=True)
            col.prop(w, "fluid_resolution")
            col.prop(w, "fluid_size")
            col.prop(w, "fluid_center")
            col.prop(w, "fluid_speed")
            col.prop(w, "fluid_decay")
            layout.prop(w, "use_continuum")
            if w.use_continuum:
                row = layout.row(align=True)
                row.prop(w, "continuum_c")
                row.prop(w, "continuum_gamma")
        row = layout.row(align=True)
        row.operator("tussock.add_wind_source", icon="FORCE_WIND")
        row.operator("tussock.wind_debug_image", icon="IMAGE_DATA")
        obj = context.active_object
        s = compat.settings_of(obj, "tussock_wind_source")
        if s is not None and s.is_source:
            box = layout.box()
            box.label(text=f"Source: {obj.name} (keyframe these)")
            box.prop(s, "strength")
            box.prop(s, "radius")
            box.prop(s, "interval")


classes = (TUSSOCK_PT_wind,)
