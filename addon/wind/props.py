"""Wind settings: the scene's global wind (steady wind, up to 8 sine waves, gusts, the
fluid grid and the wave continuum) and the Tussock properties of a wind source empty.
Every value is keyframable, so wind changes along the timeline."""

import bpy

MAX_WAVES = 8


class TussockWindWave(bpy.types.PropertyGroup):
    amplitude: bpy.props.FloatProperty(name="Amplitude", default=1.0, min=0.0, max=100.0,
                                       description="Peak wind speed of this wave, m/s")
    direction: bpy.props.FloatProperty(name="Direction", default=0.0, subtype="ANGLE",
                                       description="Heading on the ground plane (0 = +X)")
    wavelength: bpy.props.FloatProperty(name="Wavelength", default=8.0, min=0.01, max=1e5,
                                        unit="LENGTH",
                                        description="Distance between crests")
    speed: bpy.props.FloatProperty(name="Speed", default=3.0, min=-1000.0, max=1000.0,
                                   unit="VELOCITY", description="Speed of the crests")
    phase: bpy.props.FloatProperty(name="Phase", default=0.0, subtype="ANGLE", min=-1e4,
                                   max=1e4,
                                   description="Shift of the wave along its direction")
    power: bpy.props.FloatProperty(name="Sharpness", default=2.0, min=0.1, max=64.0,
                                   description="Peak power k of seed 001 eq. 14: 1 is a "
                                   "plain sine; larger gives sharp gusts and wide calms")


class TussockSceneWind(bpy.types.PropertyGroup):
    base_speed: bpy.props.FloatProperty(name="Steady wind", default=1.0, min=0.0, max=100.0,
                                        unit="VELOCITY",
                                        description="Speed of the wind that always blows")
    base_direction: bpy.props.FloatProperty(name="Direction", default=0.0, subtype="ANGLE",
                                            description="Heading of the steady wind on the ground "
                                                        "plane (0 = +X)")
    waves: bpy.props.CollectionProperty(type=TussockWindWave,
                                        description="Sine waves added to the steady wind (seed "
                                                    "001, eq. 11-14)")
    gust_strength: bpy.props.FloatProperty(name="Gusts", default=0.0, min=0.0, max=100.0,
                                           unit="VELOCITY", description="Peak extra speed")
    gust_interval: bpy.props.FloatProperty(name="Gust interval", default=4.0, min=0.01, max=1e6,
                                           unit="TIME_ABSOLUTE",
                                           description="Mean time between gusts")
    gust_duration: bpy.props.FloatProperty(name="Gust duration", default=1.5, min=0.01, max=1e6,
                                           unit="TIME_ABSOLUTE",
                                           description="How long a gust blows")
    gust_front_speed: bpy.props.FloatProperty(name="Gust front speed", default=6.0, min=0.0,
                                              max=1e4, unit="VELOCITY",
                                              description="Speed at which a gust front travels "
                                                          "over the ground")
    seed: bpy.props.IntProperty(name="Seed", default=1, min=0,
                                description="Random seed of the gusts")
    use_fluid: bpy.props.BoolProperty(name="Fluid wind", default=False,
                                      description="Simulate a 2D stable-fluids wind over "
                                      "the ground, pushed by wind source empties")
    fluid_resolution: bpy.props.IntProperty(name="Resolution", default=64, min=4, max=1024,
                                            description="Cells per side of the fluid wind grid")
    # cells of 1 mm to 10 km (tsk_wind_fluid_def_validate) at every resolution, 4 to 1024
    fluid_size: bpy.props.FloatProperty(name="Size", default=20.0, min=1.024, max=4e4,
                                        unit="LENGTH",
                                        description="Side of the square wind grid")
    # the grid's corner must stay within 1000 km of the origin (fluid.origin_x, origin_y)
    fluid_center: bpy.props.FloatVectorProperty(name="Center", size=2, default=(0.0, 0.0),
                                                min=-9.8e5, max=9.8e5,
                                                unit="LENGTH",
                                                description="Centre of the fluid wind grid on the "
                                                            "ground")
    fluid_speed: bpy.props.FloatProperty(name="Fluid speed", default=4.0, min=0.0,
                                         max=100.0, unit="VELOCITY",
                                         description="Wind speed of a full-strength source")
    fluid_decay: bpy.props.FloatProperty(name="Decay", default=0.2, min=0.0, max=100.0,
                                         description="1/s: how fast the fluid wind dies down "
                                                     "without sources")
    use_continuum: bpy.props.BoolProperty(name="Wave continuum", default=True,
                                          description="Pictures sway as a wave continuum driven "
                                                      "by the wind (seed 004, eq. 3-4)")
    continuum_c: bpy.props.FloatProperty(name="Wave speed c", default=2.0, min=0.0, max=1e5,
                                         unit="VELOCITY",
                                         description="Speed at which sway travels through a "
                                                     "picture's vegetation")
    continuum_gamma: bpy.props.FloatProperty(name="Damping γ", default=0.96, min=0.0,
                                             max=1.0,
                                             description="Per-step damping of the sway (1 = none)")


class TussockWindSource(bpy.types.PropertyGroup):
    is_source: bpy.props.BoolProperty(default=False, options={"HIDDEN"})
    strength: bpy.props.FloatProperty(name="Strength", default=0.8, min=0.0, max=1.0,
                                      description="Normalised speed at the centre (0..1)")
    radius: bpy.props.FloatProperty(name="Radius", default=1.5, min=0.001, max=1e6,
                                    unit="LENGTH",
                                    description="Reach of the source's push")
    interval: bpy.props.FloatProperty(name="Interval", default=0.0, min=0.0, max=1e6,
                                      unit="TIME_ABSOLUTE",
                                      description="Seconds between pushes (0 = continuous)")


classes = (TussockWindWave, TussockSceneWind, TussockWindSource)


def register_extra():
    bpy.types.Scene.tussock_wind = bpy.props.PointerProperty(type=TussockSceneWind)
    bpy.types.Object.tussock_wind_source = bpy.props.PointerProperty(type=TussockWindSource)


def unregister_extra():
    del bpy.types.Object.tussock_wind_source
    del bpy.types.Scene.tussock_wind
