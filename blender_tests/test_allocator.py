"""addon/allocator.py: where Blender allocates through jemalloc (Debian's 3.4 and 4.3), the
add-on makes it keep lazily freed pages for reuse, so that a tree rewritten every frame stops
faulting its pages back in; the preference and disabling the add-on put the allocator back as
Blender had it. Where Blender uses another allocator (Debian sid's 5.x: TBB's) nothing is
touched. Page faults are counted (getrusage), not timed."""

import os
import resource
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402
from harness import test  # noqa: E402

import bpy  # noqa: E402

harness.enable_addon()
from tussock import allocator, prefs  # noqa: E402

KIND, FOUND = allocator.state()


def jemalloc_linked():
    with open("/proc/self/maps") as f:
        return "libjemalloc" in f.read()


def faults_per_frame(scene, frames):
    scene.frame_set(1)
    scene.frame_set(2)  # the first frames allocate what later ones reuse
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for f in range(3, 3 + frames):
        scene.frame_set(f)
    return (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / frames


@test
def test_found_where_blender_links_jemalloc():
    assert (KIND == "jemalloc") == jemalloc_linked(), (KIND, bpy.app.version_string)
    if KIND is None:
        assert allocator.keep_freed(True) is False  # nothing to set, nothing set
        print(f"test_allocator: Blender {bpy.app.version_string} does not use jemalloc")
        return
    assert FOUND == allocator.KEEP, FOUND  # the add-on is enabled with the default preference


@test
def test_a_swaying_tree_stops_faulting_its_pages():
    if KIND is None:
        return
    bpy.ops.wm.read_factory_settings(use_empty=True)
    harness.enable_addon()
    scene = bpy.context.scene
    scene.tussock_wind.base_speed = 4.0
    assert bpy.ops.tussock.add_tree(preset="ca_black_oak", seed=1, leaves=True) == {"FINISHED"}
    verts = len(bpy.context.active_object.data.vertices)
    p = prefs.get()
    p.keep_freed_memory = False
    off = faults_per_frame(scene, 8)
    assert allocator.state()[1] != allocator.KEEP
    p.keep_freed_memory = True
    on = faults_per_frame(scene, 8)
    assert allocator.state()[1] == allocator.KEEP
    print(f"test_allocator: {verts:,} vertices, {off:,.0f} page faults a frame given back, "
          f"{on:,.0f} kept")
    if bpy.app.version < (3, 5):
        # Blender 3.4 copies the whole mesh for evaluation (tens of MB: thousands of pages),
        # faulted in every frame when freed pages go back at once
        assert off > 2000 and on < off / 4, (off, on)
    else:
        # from 3.5 the evaluated mesh shares all but the positions: little churn to save
        assert on <= off + 50, (off, on)


@test
def test_preference_and_disabling_put_the_allocator_back():
    if KIND is None:
        return
    p = prefs.get()
    p.keep_freed_memory = False
    found = allocator.state()[1]
    assert found != allocator.KEEP, found  # Blender's own value (0 in Debian's builds)
    p.keep_freed_memory = True
    assert allocator.state()[1] == allocator.KEEP
    harness.disable_addon()
    assert allocator.state()[1] == found, (allocator.state(), found)
    harness.enable_addon()
    assert allocator.state()[1] == allocator.KEEP


if __name__ == "__main__":
    harness.main()
