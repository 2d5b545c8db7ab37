"""Meadow settings, stored on the meadow object so that every meadow has its own and they
travel with the .blend. Changing one rebuilds the meadow's instances interactively."""

import bpy

from .. import errors, meshes, native
from . import blade_objects, build, simulate


def _rebuild(self, context):
    obj = self.id_data
    if not self.is_meadow or not native.available():
        return
    # the native work raises before the meadow changes: the last good meadow stays, and
    # the panel shows why; in Edit Mode, the meadow is rebuilt once out of it
    if not errors.in_update(self, build.rebuild, obj) and meshes.in_edit_mode(obj):
        meshes.redo_after_edit_mode(obj, _rebuild_later)


def _rebuild_later(obj):
    settings = getattr(obj, "tussock_meadow", None)
    if settings is not None and settings.is_meadow:
        errors.in_update(settings, build.rebuild, obj)


def _reset_simulation(self, context):
    simulate.forget(self.id_data)
    if self.is_meadow and self.use_simulation and native.available():
        # now, not in the middle of playback
        errors.in_update(self, blade_objects.ensure_chunks, self.id_data, clear=False)


DENSITY_ITEMS = [
    ("NOISE", "Noise", "Perlin-noise density map (seed 000, Fig. 8)"),
    ("UNIFORM", "Uniform", "Every tile has the full number of blades"),
    ("IMAGE", "Image", "Density from an image painted or loaded by the artist (white = full)"),
]


# Tooltips shared by the settings and the operator that takes them.
TIPS = {
    "tile_size": "Side of a square tile: the meadow is a grid of tiles, each an instance of part "
                 "of the patch",
    "blades_per_tile": "Blades in a tile where the density is full",
    "patch_blades": "Blades in the patch that all tiles reuse",
    "chunk_blades": "Blades per instanced chunk; counts per tile are multiples of it",
    "scale_min": "Smallest random scale of a blade",
    "scale_max": "Largest random scale of a blade",
    "density": "How the number of blades varies over the ground",
    "noise_scale": "Size of the patches of the noise density (Perlin noise, seed 000)",
    "noise_octaves": "Octaves of the noise density: more add finer detail",
    "noise_threshold": "Noise below this value grows no blades: higher leaves more bare ground",
    "density_image": "Image whose brightness is the density over the ground (white = full)",
    "seed": "Random seed of blade placement, scale and turn",
    "display": "Fraction of instances shown in the viewport, simulated blades included (the same "
               "blades as the instances they replace); renders show all",
    "sim_iterations": "Constraint iterations per step: more keep lengths stiffer, at more cost",
}


class TussockMeadowSettings(bpy.types.PropertyGroup):
    is_meadow: bpy.props.BoolProperty(default=False, options={"HIDDEN"})
    last_error: bpy.props.StringProperty(default="", options={"HIDDEN"})
    ground: bpy.props.PointerProperty(name="Ground", type=bpy.types.Object,
                                      description="Mesh whose extent the meadow covers",
                                      update=_rebuild)
    models: bpy.props.PointerProperty(name="Blade models", type=bpy.types.Collection,
                                      description="Collection of blade objects to grow "
                                      "(empty: Tussock's default blade)", update=_rebuild)
    tile_size: bpy.props.FloatProperty(name="Tile size", default=0.25, min=0.01, max=100.0,
                                       unit="LENGTH", update=_rebuild,
                                       description=TIPS["tile_size"])
    blades_per_tile: bpy.props.IntProperty(name="Blades per tile", default=64, min=1,
                                           max=65536, update=_rebuild,
                                           description=TIPS["blades_per_tile"])
    patch_blades: bpy.props.IntProperty(name="Patch size", default=16384, min=16,
                                        max=1 << 20, update=_rebuild,
                                        description=TIPS["patch_blades"])
    chunk_blades: bpy.props.IntProperty(name="Chunk", default=16, min=1, max=65536,
                                        update=_rebuild,
                                        description=TIPS["chunk_blades"])
    scale_min: bpy.props.FloatProperty(name="Scale min", default=0.8, min=0.01, max=100.0,
                                       update=_rebuild,
                                       description=TIPS["scale_min"])
    scale_max: bpy.props.FloatProperty(name="Scale max", default=1.2, min=0.01, max=100.0,
                                       update=_rebuild,
                                       description=TIPS["scale_max"])
    density: bpy.props.EnumProperty(name="Density", items=DENSITY_ITEMS, default="NOISE",
                                    update=_rebuild,
                                    description=TIPS["density"])
    noise_scale: bpy.props.FloatProperty(name="Noise scale", default=8.0, min=0.01,
                                         unit="LENGTH", update=_rebuild,
                                         description=TIPS["noise_scale"])
    noise_octaves: bpy.props.IntProperty(name="Octaves", default=3, min=1, max=12,
                                         update=_rebuild,
                                         description=TIPS["noise_octaves"])
    noise_threshold: bpy.props.FloatProperty(name="Threshold", default=0.2, min=0.0,
                                             max=0.99, update=_rebuild,
                                             description=TIPS["noise_threshold"])
    density_image: bpy.props.PointerProperty(name="Density image", type=bpy.types.Image,
                                             update=_rebuild,
                                             description=TIPS["density_image"])
    seed: bpy.props.IntProperty(name="Seed", default=1, min=0, update=_rebuild,
                                description=TIPS["seed"])
    display: bpy.props.FloatProperty(name="Viewport display", default=0.25, min=0.0,
                                     max=1.0, subtype="FACTOR", update=_rebuild,
                                     description=TIPS["display"])
    use_simulation: bpy.props.BoolProperty(name="Simulate touched blades", default=False,
                                           update=_reset_simulation,
                                           description="Blades that the colliders touch are "
                                           "pushed aside and recover (seed 000)")
    colliders: bpy.props.PointerProperty(name="Colliders", type=bpy.types.Collection,
                                         update=_reset_simulation,
                                         description="Objects that push blades aside: each "
                                         "gets shapes fitted every frame (the Collider panel "
                                         "of the Tussock sidebar; rigid bodies too)")
    sim_iterations: bpy.props.IntProperty(name="Iterations", default=4, min=1, max=64,
                                          update=_reset_simulation,
                                          description=TIPS["sim_iterations"])
    sim_damping: bpy.props.FloatProperty(name="Damping", default=4.0, min=0.0, max=1000.0,
                                         update=_reset_simulation,
                                         description="1/s: how fast blade motion dies down")
    sim_stiffness: bpy.props.FloatProperty(name="Shape stiffness", default=30.0, min=0.0,
                                           max=10000.0, update=_reset_simulation,
                                           description="1/s: pull toward the rest shape at "
                                           "the root")
    sim_local_stiffness: bpy.props.FloatProperty(name="Bending stiffness", default=120.0,
                                                 min=0.0, max=100000.0, update=_reset_simulation,
                                                 description="1/s: how strongly each segment "
                                                 "keeps its bend relative to its parent")
    sim_settle_time: bpy.props.FloatProperty(name="Settle after", default=2.5, min=0.05,
                                             max=600.0, unit="TIME_ABSOLUTE",
                                             update=_reset_simulation,
                                             description="Seconds after the last touch when a "
                                             "tile that wind keeps moving slides back to rest "
                                             "and stops being simulated")


classes = (TussockMeadowSettings,)


def register_extra():
    bpy.types.Object.tussock_meadow = bpy.props.PointerProperty(type=TussockMeadowSettings)


def unregister_extra():
    del bpy.types.Object.tussock_meadow
