"""The memory a tree mesh or a meadow will take, Tussock's and Blender's together, checked
against the native memory budget (tsk_memory_budget: half the machine's memory unless set)
before anything large is built. The native checks count Tussock's own buffers only, and
Blender holds several times more for the same mesh (its mesh, the depsgraph's copy, the
undo step and the viewport's draw buffers): a weeping willow at Smooth 3 passed them and
then froze Blender for 43 s at 8 GB (issue 32). Now it is refused at once (its estimate:
Tussock 7.1 GiB with OpenSubdiv, Blender 6.8 GiB).

One tree or meadow may take at most half of the budget, a quarter of the machine's memory
by default (OBJECT_SHARE). That is a choice, not a measurement: the estimate is one object's
cost with one render, and the rest of the scene, the undo history, Blender's other windows
and the artist's other programs need the rest. So a 64M-blade meadow (4M instances,
estimated at 8.6 GB with a render, whose 32x32 render peaked at 5.5 GB and took 6 minutes)
is refused on a 24 GiB machine (a 6 GiB share), while a 16M-blade one (2.1 GB) is accepted.

Blender's costs were measured with tools/blender_memory.py: the growth of the process's
resident memory when the operator adds the mesh in a window (xvfb, Mesa: the draw buffers
in main memory, as an integrated GPU has them; the undo step included), less Tussock's own
held buffers, for the weeping willow at Smooth 0, 1 and 2 (2-20 M corners), in Blender 3.4.1
and 5.2.2. That growth is 3.2-3.3x the size of Blender 3.4's mesh arrays (vertex 16 B + its
normal 12 B; edge 12 B; face 12 B + material index 4 B + normal 12 B; corner 8 B; UV corner
8 B + 3 B of selection flags); the constants are that layout x 3.3, and fit the three
window measurements within 4 %. Blender 5.2.2 held less for the same trees (386 and 501 MB
for the willow at Smooth 0 and 1 against 3.4.1's 506 and 723 MB), so one set of constants
serves both. In background Blender (no undo, no drawing) 3.4.1 held about 60 % of it."""

from . import native

MIB = 1 << 20

OBJECT_SHARE = 0.5  # of the memory budget, for one tree or meadow (see above)

# Blender's bytes per element of a tree mesh (see above)
BLENDER_PER_VERTEX = 92
BLENDER_PER_EDGE = 40
BLENDER_PER_FACE = 92
BLENDER_PER_CORNER = 26
BLENDER_PER_UV_CORNER = 36  # a mesh with a UV map: trees without smoothing

# Tussock's bytes for a tree: the cage's arrays in Python and C (positions and the pose
# buffer 24 B per vertex; per quad its indices, UVs, edges and corner edges 96 B), and per
# subdivided face what OpenSubdiv's refiner and stencils, the refined faces and positions
# hold at the peak (tools/blender_memory.py "tree": 310-380 B per refined face of the
# willow at Smooth 1 and 2)
TUSSOCK_PER_CAGE_VERTEX = 24
TUSSOCK_PER_CAGE_QUAD = 96
TUSSOCK_PER_REFINED_FACE = 400


# A meadow's cost per chunk instance (a point of the meadow's mesh, instanced by geometry
# nodes): Blender's in a window once the viewport has drawn it (tools/blender_memory.py
# "window_meadow", 102,400 and 640,000 instances: 453 B each in 3.4.1 and 495 B in 5.2.2,
# beyond a fixed 270-370 MB) and what a render adds ("meadow N CYCLES": a 32x32 Cycles
# render of one sample; 1.5 KB each at 640,000 instances in 3.4.1, 1.66 KB in 5.2.2, fixed
# costs included; 1.26 KB at the 4,000,000 instances of issue 32's 64M-blade meadow in
# 3.4.1, whose render took 6 minutes); Tussock's: the native layout (20 B per instance and
# per tile, tsk_meadow_create's own check) and the arrays that carry the instances into
# Blender (origins, chunk, viewport and hidden flags: 22 B).
BLENDER_PER_INSTANCE = 500 + 1600
TUSSOCK_PER_INSTANCE = 20 + 22
TUSSOCK_PER_TILE = 20


def _mib(n):
    return f"{n / MIB:,.0f} MiB"


def check(what, tussock_bytes, blender_bytes, advice):
    """Raises ValueError when Tussock's and Blender's estimates together exceed what one
    object may take, in the native checks' words ("needs about N MiB, more than ...") with
    the two parts and what to do; else returns (the estimate, that share)."""
    budget = native.require().memory_budget()
    share = int(budget * OBJECT_SHARE)
    total = tussock_bytes + blender_bytes
    if total > share:
        raise ValueError(f"{what}: needs about {_mib(total)} (Tussock {_mib(tussock_bytes)}, "
                         f"Blender {_mib(blender_bytes)}), more than the {_mib(share)} one "
                         f"object may take ({100 * OBJECT_SHARE:.0f} % of the memory budget of "
                         f"{_mib(budget)}): {advice}")
    return total, share


def note(estimate):
    """What to tell the artist about an accepted estimate (total, share): '' when it is
    small, else how much memory the result will hold, so a large one is never silent."""
    total, share = estimate
    if total <= share / 4:
        return ""
    return (f"it will hold about {_mib(total)} of memory ({100 * total / share:.0f} % of what "
            f"one object may take, {_mib(share)})")


def tree_counts(vertices, quads, cage_vertices, cage_quads, smooth_levels):
    """(vertices, edges, faces, corners, refined faces) of a tree's Blender mesh: `vertices`
    and `quads` of the whole cage (branches and leaves), `cage_*` of the branches alone,
    which Catmull-Clark refines `smooth_levels` times (V' = V + E + F, E' = 2E + 4F,
    F' = 4F; the branch cage's edges taken as V + F, as for open tubes)."""
    leaf_vertices, leaf_quads = vertices - cage_vertices, quads - cage_quads
    v, e, f = float(cage_vertices), float(cage_vertices + cage_quads), float(cage_quads)
    for _ in range(smooth_levels):
        v, e, f = v + e + f, 2.0 * e + 4.0 * f, 4.0 * f
    refined = f if smooth_levels > 0 else 0.0
    faces = f + leaf_quads
    return v + leaf_vertices, e + leaf_vertices, faces, 4.0 * faces, refined


def check_tree(vertices, quads, cage_vertices, cage_quads, smooth_levels):
    v, e, f, corners, refined = tree_counts(vertices, quads, cage_vertices, cage_quads,
                                            smooth_levels)
    tussock = (vertices * TUSSOCK_PER_CAGE_VERTEX + quads * TUSSOCK_PER_CAGE_QUAD
               + refined * TUSSOCK_PER_REFINED_FACE)
    blender = (v * BLENDER_PER_VERTEX + e * BLENDER_PER_EDGE + f * BLENDER_PER_FACE
               + corners * (BLENDER_PER_CORNER
                            + (BLENDER_PER_UV_CORNER if smooth_levels == 0 else 0)))
    check(f"the tree's mesh ({v:,.0f} vertices, {f:,.0f} faces)", tussock, blender,
          "lower Smooth, or grow a smaller tree (fewer levels, branches or leaves)")


def check_meadow(tiles, instances, blades):
    tussock = tiles * TUSSOCK_PER_TILE + instances * TUSSOCK_PER_INSTANCE
    blender = instances * BLENDER_PER_INSTANCE
    return check(f"the meadow ({blades:,} blades in {instances:,} instances)", tussock, blender,
                 "cover less ground, or use larger tiles, fewer blades per tile or larger chunks")
