"""The Wind panel in the Tussock sidebar tab: the scene's wind (with Waves, Gusts and Fluid
sub-panels, Fluid's Continuum inside it) and the selected source."""

import bpy

from .. import compat
from ..ui import SubPanel


def _split(layout):
    layout.use_property_split = True
    layout.use_property_decorate = True


def _source(context):
    """The active object's wind source settings, or None when it is not a source."""
    s = compat.settings_of(context.active_object, "tussock_wind_source")
    return s if s is not None and s.is_source else None


# a wave's settings with labels that fit the label column at the default sidebar width
WAVE_LABELS = (("amplitude", "Amplitude"), ("direction", "Direction"), ("wavelength", "Length"),
               ("speed", "Speed"), ("phase", "Phase"), ("power", "Sharpness"))


class TUSSOCK_PT_wind(SubPanel, bpy.types.Panel):
    bl_label = "Wind"
    bl_idname = "TUSSOCK_PT_wind"

    def draw(self, context):
        layout = self.layout
        _split(layout)
        w = context.scene.tussock_wind
        col = layout.column(align=True)
        col.prop(w, "base_speed", text="Speed")
        col.prop(w, "base_direction", text="Direction")
        layout.prop(w, "seed")
        col = layout.column(align=True)
        col.operator("tussock.add_wind_source", icon="FORCE_WIND")
        col.operator("tussock.wind_debug_image", icon="IMAGE_DATA")


class WindSubPanel(SubPanel):
    bl_parent_id = "TUSSOCK_PT_wind"
    bl_options = {"DEFAULT_CLOSED"}


class TUSSOCK_PT_wind_source(WindSubPanel, bpy.types.Panel):
    bl_label = "Selected Source"
    bl_idname = "TUSSOCK_PT_wind_source"
    bl_options = set()

    @classmethod
    def poll(cls, context):
        return _source(context) is not None

    def draw(self, context):
        layout = self.layout
        _split(layout)
        s = _source(context)
        layout.label(text=context.active_object.name, icon="FORCE_WIND")
        col = layout.column()
        col.prop(s, "strength")
        col.prop(s, "radius")
        col.prop(s, "interval")


class TUSSOCK_PT_wind_waves(WindSubPanel, bpy.types.Panel):
    bl_label = "Waves"
    bl_idname = "TUSSOCK_PT_wind_waves"

    def draw(self, context):
        layout = self.layout
        _split(layout)
        w = context.scene.tussock_wind
        for i, wave in enumerate(w.waves):
            head = layout.row()
            head.label(text=f"Wave {i + 1}")
            head.operator("tussock.wind_wave_remove", text="", icon="X", emboss=False).index = i
            col = layout.column(align=True)
            for name, text in WAVE_LABELS:
                col.prop(wave, name, text=text)
            layout.separator()
        layout.operator("tussock.wind_wave_add", icon="ADD")


class TUSSOCK_PT_wind_gusts(WindSubPanel, bpy.types.Panel):
    bl_label = "Gusts"
    bl_idname = "TUSSOCK_PT_wind_gusts"

    def draw(self, context):
        layout = self.layout
        _split(layout)
        w = context.scene.tussock_wind
        col = layout.column(align=True)
        col.prop(w, "gust_strength", text="Strength")
        col.prop(w, "gust_interval", text="Interval")
        col.prop(w, "gust_duration", text="Duration")
        col.prop(w, "gust_front_speed", text="Speed")


class TUSSOCK_PT_wind_fluid(WindSubPanel, bpy.types.Panel):
    bl_label = "Fluid"
    bl_idname = "TUSSOCK_PT_wind_fluid"

    def draw_header(self, context):
        self.layout.prop(context.scene.tussock_wind, "use_fluid", text="")

    def draw(self, context):
        layout = self.layout
        _split(layout)
        w = context.scene.tussock_wind
        layout.active = w.use_fluid
        col = layout.column(align=True)
        col.prop(w, "fluid_resolution")
        col.prop(w, "fluid_size")
        layout.prop(w, "fluid_center")
        col = layout.column(align=True)
        col.prop(w, "fluid_speed", text="Speed")
        col.prop(w, "fluid_decay")


class TUSSOCK_PT_wind_continuum(SubPanel, bpy.types.Panel):
    bl_label = "Wave Continuum"
    bl_idname = "TUSSOCK_PT_wind_continuum"
    bl_parent_id = "TUSSOCK_PT_wind_fluid"

    def draw_header(self, context):
        w = context.scene.tussock_wind
        self.layout.active = w.use_fluid
        self.layout.prop(w, "use_continuum", text="")

    def draw(self, context):
        layout = self.layout
        _split(layout)
        w = context.scene.tussock_wind
        layout.active = w.use_fluid and w.use_continuum
        col = layout.column(align=True)
        col.prop(w, "continuum_c", text="Speed c")
        col.prop(w, "continuum_gamma", text="Damping")


classes = (TUSSOCK_PT_wind, TUSSOCK_PT_wind_waves, TUSSOCK_PT_wind_gusts,
           TUSSOCK_PT_wind_fluid, TUSSOCK_PT_wind_continuum, TUSSOCK_PT_wind_source)
