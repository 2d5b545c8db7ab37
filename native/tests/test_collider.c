/* Tests of the collider fits (tussock/collider.h) against shapes whose answer is known:
 * limbs that are cylinders about their bones (the capsule is the cylinder's), a posed bone
 * (the rows are the rest rows moved by the pose), a cube and an L-shaped prop (every point of
 * every face inside a sphere; the open corner of the L mostly outside), closed meshes of known
 * volume, every refused input, and a golden hash of the bytes a Windows build must repeat. */
#include "test.h"
#include "tussock/collider.h"

static const double PI = 3.14159265358979323846;

/* row-major 4x4 identity, then a translation */
static void identity(float m[16]) {
    memset(m, 0, 16 * sizeof(float));
    m[0] = m[5] = m[10] = m[15] = 1.0f;
}
static void translate(float m[16], float x, float y, float z) {
    identity(m);
    m[3] = x, m[7] = y, m[11] = z;
}

/* distance from p to the segment a-b */
static double seg_dist(const double p[3], const float a[3], const float b[3]) {
    double d[3], q[3], dd = 0, qd = 0;
    for (int k = 0; k < 3; ++k) {
        d[k] = b[k] - a[k];
        q[k] = p[k] - a[k];
        dd += d[k] * d[k];
        qd += q[k] * d[k];
    }
    double s = dd > 0 ? qd / dd : 0;
    s = s < 0 ? 0 : (s > 1 ? 1 : s);
    double e = 0;
    for (int k = 0; k < 3; ++k) e += (q[k] - s * d[k]) * (q[k] - s * d[k]);
    return sqrt(e);
}

/* n points on a cylinder of radius r about the segment from `from` along unit `axis` for
 * `len` metres, caps included, into pts (3 * n floats) */
static void cylinder(float* pts, int n, const double from[3], const double axis[3], double len,
                     double r) {
    double u[3] = {0, 0, 1};
    if (fabs(axis[2]) > 0.9) u[0] = 1, u[2] = 0;
    double v[3] = {axis[1] * u[2] - axis[2] * u[1], axis[2] * u[0] - axis[0] * u[2],
                   axis[0] * u[1] - axis[1] * u[0]};
    double nv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; ++k) v[k] /= nv;
    double w[3] = {axis[1] * v[2] - axis[2] * v[1], axis[2] * v[0] - axis[0] * v[2],
                   axis[0] * v[1] - axis[1] * v[0]};
    for (int i = 0; i < n; ++i) {
        const double t = len * (i % 17) / 16.0, a = 2 * PI * (i % 23) / 23.0;
        const double rr = (i % 5 == 0) ? r * (i % 7) / 7.0 : r; /* some inside, on the caps */
        for (int k = 0; k < 3; ++k)
            pts[3 * i + k] = (float)(from[k] + t * axis[k] + rr * (cos(a) * v[k] + sin(a) * w[k]));
    }
}

/* A leg of two bones along +y (thigh 0..0.4, shin 0.4..0.8) and a toe (0.8..0.82) whose skin
 * is a cylinder of radius 0.06 about them; bone 3 is a control bone that deforms nothing. */
enum { LEG_POINTS = 2 * 391 + 40 };
typedef struct leg {
    float pts[3 * LEG_POINTS], heads[12], tails[12], rest[64];
    int32_t parent[4];
    uint8_t deforms[4];
} leg;

static void make_leg(leg* g) {
    const double up[3] = {0, 1, 0};
    for (int b = 0; b < 3; ++b) {
        const double y0 = 0.4 * b, len = b < 2 ? 0.4 : 0.02;
        const double from[3] = {0.1, y0, -0.2};
        cylinder(g->pts + 3 * 391 * b, b < 2 ? 391 : 40, from, up, len, 0.06);
        g->heads[3 * b] = 0.1f, g->heads[3 * b + 1] = (float)y0, g->heads[3 * b + 2] = -0.2f;
        g->tails[3 * b] = 0.1f, g->tails[3 * b + 1] = (float)(y0 + len),
                     g->tails[3 * b + 2] = -0.2f;
        translate(g->rest + 16 * b, 0.1f, (float)y0, -0.2f); /* bone y is armature y */
        g->parent[b] = b - 1;
        g->deforms[b] = 1;
    }
    /* the control bone lies along the leg's middle: nearest, but it deforms nothing */
    g->heads[9] = 0.1f, g->heads[10] = 0.0f, g->heads[11] = -0.2f;
    g->tails[9] = 0.1f, g->tails[10] = 0.8f, g->tails[11] = -0.2f;
    translate(g->rest + 48, 0.1f, 0.0f, -0.2f);
    g->parent[3] = -1;
    g->deforms[3] = 0;
}

/* is p (armature space) inside one of the fitted rows (bone space; the rest matrices here
 * are translations) */
static int inside_any(const double p[3], const float* fit, const float* rest, int bones,
                      double tol) {
    for (int b = 0; b < bones; ++b) {
        const float* row = fit + 8 * b;
        if (row[0] < 0) continue;
        double q[3];
        for (int k = 0; k < 3; ++k) q[k] = p[k] - rest[16 * b + 4 * k + 3];
        if (seg_dist(q, row + 2, row + 5) <= row[1] + tol) return 1;
    }
    return 0;
}

static int all_inside(const float* pts, int n, const float* fit, const float* rest, int bones) {
    for (int i = 0; i < n; ++i) {
        const double p[3] = {pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]};
        if (!inside_any(p, fit, rest, bones, 1e-6)) return 0;
    }
    return 1;
}

/* The leg's bones fitted in an armature frame that is the leg's own. */
static tsk_status fit_leg(const leg* g, float min_size, float* out, int32_t* group) {
    float to_arm[16];
    identity(to_arm);
    return tsk_collider_fit_bones(g->pts, LEG_POINTS, to_arm, g->heads, g->tails, g->rest,
                                  g->parent, g->deforms, 4, min_size, out, group);
}

TEST(test_bone_capsules_are_the_limbs_cylinders) {
    leg g;
    make_leg(&g);
    float out[32];
    CHECK(fit_leg(&g, 0.0f, out, NULL) == TSK_OK);
    for (int b = 0; b < 2; ++b) { /* thigh and shin: the cylinder of radius 0.06, length 0.4 */
        const float* r = out + 8 * b;
        CHECK(r[0] == 1.0f);
        CHECK_NEAR(r[1], 0.06, 1e-6);
        CHECK_NEAR(r[2], 0.0, 1e-6); /* on the bone's y axis, in bone space */
        CHECK_NEAR(r[4], 0.0, 1e-6);
        /* the rims at the ends are on the radius: the segment spans the bone's length, less
         * the rim at the knee that one of the two bones takes */
        CHECK(r[3] > -1e-6 && r[3] < 0.026);
        CHECK(r[6] > 0.374 && r[6] < 0.4 + 1e-6);
    }
    CHECK(all_inside(g.pts, LEG_POINTS, out, g.rest, 4));
    CHECK(out[16] == 0.0f || out[16] == 1.0f); /* the toe has its own shape without a limit */
    CHECK(out[24] == -1.0f && out[25] == 0.0f); /* the control bone holds no point */
}

TEST(test_small_bones_give_their_points_to_their_parent) {
    leg g;
    make_leg(&g);
    float out[32];
    CHECK(fit_leg(&g, 0.15f, out, NULL) == TSK_OK);
    CHECK(out[16] == -1.0f); /* the toe (0.12 across) went to the shin */
    CHECK(out[8] == 1.0f);
    CHECK(all_inside(g.pts, LEG_POINTS, out, g.rest, 4));
    CHECK_NEAR(out[8 + 6], 0.42, 1e-4); /* the shin's capsule reaches the toe's end */
    /* a limit above everything merges all into the root: one shape holds the whole leg */
    CHECK(fit_leg(&g, 10.0f, out, NULL) == TSK_OK);
    CHECK(out[0] == 1.0f && out[8] == -1.0f && out[16] == -1.0f);
    CHECK(all_inside(g.pts, LEG_POINTS, out, g.rest, 4));
    CHECK_NEAR(out[1], 0.06, 1e-6);
}

TEST(test_a_bone_at_an_angle_fits_along_its_own_axis) {
    /* one bone from the origin along (1, 1, 0)/sqrt 2: its rest matrix turns y onto that
     * direction; the skin a cylinder of radius 0.1, 1 m long, in a mesh moved by +2 in z
     * (to_armature brings it back) */
    const double s = sqrt(0.5), axis[3] = {s, s, 0}, from[3] = {0, 0, 2};
    enum { N = 600 };
    float pts[3 * N], to_arm[16], rest[16], out[8];
    cylinder(pts, N, from, axis, 1.0, 0.1);
    translate(to_arm, 0, 0, -2);
    identity(rest);
    /* columns: bone x = (s, -s, 0), bone y = (s, s, 0), bone z = (0, 0, 1) */
    rest[0] = (float)s, rest[1] = (float)s, rest[4] = (float)-s, rest[5] = (float)s;
    const float heads[3] = {0, 0, 0}, tails[3] = {(float)s, (float)s, 0};
    const int32_t parent[1] = {-1};
    const uint8_t deforms[1] = {1};
    CHECK(tsk_collider_fit_bones(pts, N, to_arm, heads, tails, rest, parent, deforms, 1, 0.0f, out,
                                 NULL) == TSK_OK);
    CHECK(out[0] == 1.0f);
    CHECK_NEAR(out[1], 0.1, 1e-6);
    CHECK_NEAR(out[2], 0.0, 1e-6); /* along bone y, from its head to 1 m on */
    CHECK_NEAR(out[4], 0.0, 1e-6);
    CHECK_NEAR(out[3], 0.0, 1e-4); /* (the skin's points are floats) */
    CHECK_NEAR(out[6], 1.0, 1e-4);
}

/* row-major a @ b of 4x4 matrices */
static void mul(const float a[16], const float b[16], float out[16]) {
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            double v = 0;
            for (int k = 0; k < 4; ++k) v += (double)a[4 * r + k] * b[4 * k + c];
            out[4 * r + c] = (float)v;
        }
}

/* The leg posed: every bone turned a quarter turn about z at its head (pose = rest with the
 * turn), the armature scaled by 2 and moved +5 in x; the mesh's points moved by their bones
 * as an Armature modifier with weights of 1 moves them. Each bone's capsule now is its rest
 * capsule moved by world @ pose: the same limb in another place. */
TEST(test_posed_capsules_are_the_rest_capsules_moved_by_the_pose) {
    leg g;
    make_leg(&g);
    float fit[32], rows[32], world[16], pose[64], turn[16];
    int32_t group[LEG_POINTS];
    CHECK(fit_leg(&g, 0.0f, fit, group) == TSK_OK);
    identity(world);
    world[0] = world[5] = world[10] = 2.0f;
    world[3] = 5.0f;
    identity(turn);
    turn[0] = 0, turn[1] = -1, turn[4] = 1, turn[5] = 0;
    for (int b = 0; b < 4; ++b) mul(g.rest + 16 * b, turn, pose + 16 * b); /* rest @ turn */
    /* where the modifier puts each point, in mesh space (= armature space here): pose @
     * rest^-1 @ p, and rest^-1 is the opposite translation */
    static float now[3 * LEG_POINTS];
    for (int i = 0; i < LEG_POINTS; ++i) {
        const int b = group[i];
        CHECK(b >= 0 && b < 3);
        const float* t = g.rest + 16 * b;
        const float* m = pose + 16 * b;
        const float x = g.pts[3 * i] - t[3], y = g.pts[3 * i + 1] - t[7],
                    z = g.pts[3 * i + 2] - t[11];
        for (int k = 0; k < 3; ++k)
            now[3 * i + k] = m[4 * k] * x + m[4 * k + 1] * y + m[4 * k + 2] * z + m[4 * k + 3];
    }
    CHECK(tsk_collider_fit_groups(now, LEG_POINTS, NULL, 0, group, world, world, pose, 4, rows) ==
          TSK_OK);
    CHECK(rows[24] == -1.0f); /* the control bone has no shape */
    for (int b = 0; b < 3; ++b) {
        const float *f = fit + 8 * b, *r = rows + 8 * b;
        float m[16];
        mul(world, pose + 16 * b, m);
        CHECK(r[0] == f[0]);
        CHECK_NEAR(r[1], 2.0 * f[1], 1e-5);
        for (int e = 0; e < 2; ++e) {
            const float *p = f + 2 + 3 * e, *q = r + 2 + 3 * e;
            for (int k = 0; k < 3; ++k)
                CHECK_NEAR(
                    q[k],
                    m[4 * k] * p[0] + m[4 * k + 1] * p[1] + m[4 * k + 2] * p[2] + m[4 * k + 3],
                    1e-4);
        }
    }
}

/* a w x h x d box (centred at c) of 12 triangles */
static void box(float pts[24], int32_t tris[36], const double c[3], double w, double h, double d) {
    for (int i = 0; i < 8; ++i) {
        pts[3 * i] = (float)(c[0] + ((i & 1) ? w : -w) / 2);
        pts[3 * i + 1] = (float)(c[1] + ((i & 2) ? h : -h) / 2);
        pts[3 * i + 2] = (float)(c[2] + ((i & 4) ? d : -d) / 2);
    }
    static const int32_t t[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                  2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    memcpy(tris, t, sizeof t);
}

/* is p inside one of the n rows' spheres (within tol) */
static int in_spheres(const double p[3], const float* rows, int n, double tol) {
    for (int i = 0; i < n; ++i) {
        const float* r = rows + 8 * i;
        const double dx = p[0] - r[2], dy = p[1] - r[3], dz = p[2] - r[4];
        if (sqrt(dx * dx + dy * dy + dz * dz) <= r[1] + tol) return 1;
    }
    return 0;
}

/* every point of every triangle (a 10 x 10 barycentric grid) inside a sphere */
static int surface_covered(const float* pts, const int32_t* tris, int t, const float* rows, int n) {
    for (int k = 0; k < t; ++k)
        for (int i = 0; i <= 10; ++i)
            for (int j = 0; i + j <= 10; ++j) {
                const double a = i / 10.0, b = j / 10.0, c = 1 - a - b;
                double p[3];
                for (int q = 0; q < 3; ++q)
                    p[q] = a * pts[3 * tris[3 * k] + q] + b * pts[3 * tris[3 * k + 1] + q] +
                           c * pts[3 * tris[3 * k + 2] + q];
                if (!in_spheres(p, rows, n, 1e-5)) return 0;
            }
    return 1;
}

TEST(test_spheres_hold_every_face_of_a_cube) {
    float pts[24], rows[8 * 64], world[16];
    int32_t tris[36], n = 0;
    const double c[3] = {0, 0, 0};
    box(pts, tris, c, 1, 1, 1);
    identity(world);
    CHECK(tsk_collider_fit_spheres(pts, 8, tris, 12, world, 1, rows, &n) == TSK_OK);
    CHECK(n == 1 && rows[0] == 0.0f);
    CHECK_NEAR(rows[1], sqrt(3.0) / 2, 1e-6); /* about the centre, through the corners */
    for (int max = 2; max <= 64; max *= 4) {
        CHECK(tsk_collider_fit_spheres(pts, 8, tris, 12, world, max, rows, &n) == TSK_OK);
        CHECK(n >= 1 && n <= max && n <= 12);
        CHECK(surface_covered(pts, tris, 12, rows, n));
    }
    CHECK(n == 12); /* 12 triangles: no more leaves than that */
    /* placed by the world matrix: scale 3, moved to (1, 2, 3) */
    world[0] = world[5] = world[10] = 3.0f;
    world[3] = 1, world[7] = 2, world[11] = 3;
    CHECK(tsk_collider_fit_spheres(pts, 8, tris, 12, world, 1, rows, &n) == TSK_OK);
    CHECK_NEAR(rows[1], 3 * sqrt(3.0) / 2, 1e-5);
    CHECK(rows[2] == 1.0f && rows[3] == 2.0f && rows[4] == 3.0f);
}

TEST(test_spheres_leave_the_open_corner_of_an_l_shape_open) {
    /* an L of two 2 m x 0.4 m x 0.4 m arms meeting at the origin; its bounds fit (one capsule
     * or sphere) covers the open corner between the arms, which 64 spheres mostly leave out */
    enum { FACES = 4 * 4 * 12 };
    float pts[2 * 16 * 24];
    int32_t tris[2 * 16 * 36];
    int np = 0, nt = 0;
    for (int arm = 0; arm < 2; ++arm)
        for (int s = 0; s < 16; ++s) { /* each arm as 16 boxes along it (a finer surface) */
            const double along = 0.2 + (s + 0.5) * 0.1125;
            const double c[3] = {arm == 0 ? along : 0.2, arm == 0 ? 0.2 : along, 0.2};
            box(pts + 3 * np, tris + 3 * nt, c, arm == 0 ? 0.1125 : 0.4, arm == 0 ? 0.4 : 0.1125,
                0.4);
            for (int k = 0; k < 36; ++k) tris[3 * nt + k] += np;
            np += 8, nt += 12;
        }
    (void)FACES;
    float rows[8 * 64], world[16];
    int32_t n = 0;
    identity(world);
    CHECK(tsk_collider_fit_spheres(pts, np, tris, nt, world, 64, rows, &n) == TSK_OK);
    CHECK(n == 64);
    CHECK(surface_covered(pts, tris, nt, rows, n));
    int open = 0, covered = 0;
    for (int i = 0; i < 20; ++i) /* the corner: x, y in 0.8..2, at mid height */
        for (int j = 0; j < 20; ++j) {
            const double p[3] = {0.8 + 1.2 * i / 19.0, 0.8 + 1.2 * j / 19.0, 0.2};
            ++open;
            covered += in_spheres(p, rows, n, 0.0);
        }
    CHECK(covered * 20 < open); /* under 5 % of the open corner */
}

TEST(test_mesh_volume_of_closed_meshes) {
    float pts[24];
    int32_t tris[36];
    const double c[3] = {3, -2, 1};
    box(pts, tris, c, 1, 2, 3);
    double v = 0;
    CHECK(tsk_collider_mesh_volume(pts, 8, tris, 12, &v) == TSK_OK);
    CHECK_NEAR(v, 6.0, 1e-5);
    /* a UV sphere of radius 0.5, 64 x 32: within 0.5 % of 4/3 pi r^3 (inscribed: a bit less) */
    enum { SEG = 64, RING = 32 };
    static float sp[3 * (SEG * (RING - 1) + 2)];
    static int32_t st[3 * 2 * SEG * (RING - 1)];
    int n = 0, t = 0;
    for (int r = 1; r < RING; ++r)
        for (int s = 0; s < SEG; ++s) {
            const double th = PI * r / RING, ph = 2 * PI * s / SEG;
            sp[3 * n] = (float)(0.5 * sin(th) * cos(ph));
            sp[3 * n + 1] = (float)(0.5 * sin(th) * sin(ph));
            sp[3 * n + 2] = (float)(0.5 * cos(th));
            ++n;
        }
    const int top = n, bottom = n + 1;
    sp[3 * top] = sp[3 * top + 1] = 0, sp[3 * top + 2] = 0.5f;
    sp[3 * bottom] = sp[3 * bottom + 1] = 0, sp[3 * bottom + 2] = -0.5f;
    n += 2;
    for (int s = 0; s < SEG; ++s) {
        const int s1 = (s + 1) % SEG;
        st[3 * t] = top, st[3 * t + 1] = s, st[3 * t + 2] = s1, ++t;
        const int last = (RING - 2) * SEG;
        st[3 * t] = bottom, st[3 * t + 1] = last + s1, st[3 * t + 2] = last + s, ++t;
        for (int r = 0; r + 1 < RING - 1; ++r) {
            const int a = r * SEG + s, b = r * SEG + s1, c2 = (r + 1) * SEG + s,
                      d = (r + 1) * SEG + s1;
            st[3 * t] = a, st[3 * t + 1] = c2, st[3 * t + 2] = b, ++t;
            st[3 * t] = b, st[3 * t + 1] = c2, st[3 * t + 2] = d, ++t;
        }
    }
    CHECK(tsk_collider_mesh_volume(sp, n, st, t, &v) == TSK_OK);
    const double exact = 4.0 / 3.0 * PI * 0.125;
    CHECK(v < exact && v > 0.99 * exact);
}

TEST(test_bad_fit_inputs_are_refused) {
    leg g;
    make_leg(&g);
    float to_arm[16], out[32], rows[32], world[16];
    identity(to_arm);
    identity(world);
    int32_t count;
    g.parent[0] = 2; /* 0 -> 2 -> 1 -> 0 */
    CHECK_STATUS(fit_leg(&g, 0.0f, out, NULL), TSK_ERR_ARGUMENT, "its own ancestor");
    g.parent[0] = 0;
    CHECK_STATUS(fit_leg(&g, 0.0f, out, NULL), TSK_ERR_ARGUMENT, "parent");
    g.parent[0] = -1;
    g.rest[16 + 5] = 0, g.rest[16 + 0] = 0; /* bone 1's rest matrix flattened */
    CHECK_STATUS(fit_leg(&g, 0.0f, out, NULL), TSK_ERR_ARGUMENT, "singular");
    make_leg(&g);
    g.pts[7] = NAN;
    CHECK_STATUS(fit_leg(&g, 0.0f, out, NULL), TSK_ERR_ARGUMENT, "points");
    g.pts[7] = 3e38f;
    CHECK_STATUS(fit_leg(&g, 0.0f, out, NULL), TSK_ERR_ARGUMENT, "within");
    make_leg(&g);
    CHECK_STATUS(fit_leg(&g, -1.0f, out, NULL), TSK_ERR_ARGUMENT, "min_size");
    CHECK_STATUS(
        tsk_collider_fit_bones(g.pts, LEG_POINTS, to_arm, g.heads, g.tails, g.rest, g.parent,
                               g.deforms, TSK_COLLIDER_FIT_MAX_SHAPES + 1, 0.0f, out, NULL),
        TSK_ERR_LIMIT, "bones");
    CHECK_STATUS(tsk_collider_fit_bones(NULL, 3, to_arm, g.heads, g.tails, g.rest, g.parent,
                                        g.deforms, 4, 0.0f, out, NULL),
                 TSK_ERR_ARGUMENT, "NULL");
    int32_t group[LEG_POINTS];
    CHECK(fit_leg(&g, 0.0f, out, group) == TSK_OK);
    group[5] = 4; /* no such bone */
    CHECK_STATUS(
        tsk_collider_fit_groups(g.pts, LEG_POINTS, NULL, 0, group, world, world, g.rest, 4, rows),
        TSK_ERR_ARGUMENT, "group");
    group[5] = 0;
    world[3] = INFINITY;
    CHECK_STATUS(
        tsk_collider_fit_groups(g.pts, LEG_POINTS, NULL, 0, group, world, world, g.rest, 4, rows),
        TSK_ERR_ARGUMENT, "to_world");
    identity(world);
    g.rest[0] = g.rest[5] = 0; /* bone 0 posed flat */
    CHECK_STATUS(
        tsk_collider_fit_groups(g.pts, LEG_POINTS, NULL, 0, group, world, world, g.rest, 4, rows),
        TSK_ERR_ARGUMENT, "singular");
    float pts[24], srows[8];
    int32_t tris[36];
    const double c[3] = {0, 0, 0};
    box(pts, tris, c, 1, 1, 1);
    identity(world);
    CHECK_STATUS(tsk_collider_fit_spheres(pts, 8, tris, 12, world, 0, srows, &count),
                 TSK_ERR_ARGUMENT, "max_spheres");
    tris[5] = 8;
    CHECK_STATUS(tsk_collider_fit_spheres(pts, 8, tris, 12, world, 1, srows, &count),
                 TSK_ERR_ARGUMENT, "triangles");
    double v;
    CHECK_STATUS(tsk_collider_mesh_volume(pts, 8, tris, 12, &v), TSK_ERR_ARGUMENT, "triangle 1");
    tris[5] = -1;
    CHECK_STATUS(tsk_collider_fit_spheres(pts, 8, tris, 12, world, 1, srows, &count),
                 TSK_ERR_ARGUMENT, "triangles");
    CHECK(tsk_collider_fit_spheres(pts, 0, NULL, 0, world, 1, srows, &count) == TSK_OK &&
          count == 0);
}

/* The bytes of a leg fit, its pose and a sphere set: a Windows or other build must give the
 * same (the farm bakes on any of them). */
#define COLLIDER_GOLDEN 0xb13a41390e64cd57ull
TEST(test_fits_give_the_same_bytes_everywhere) {
    leg g;
    make_leg(&g);
    float to_arm[16], fit[32], rows[32], world[16], pose[64];
    identity(to_arm);
    to_arm[0] = 0.8f, to_arm[1] = 0.6f, to_arm[4] = -0.6f, to_arm[5] = 0.8f; /* turned */
    CHECK(tsk_collider_fit_bones(g.pts, LEG_POINTS, to_arm, g.heads, g.tails, g.rest, g.parent,
                                 g.deforms, 4, 0.05f, fit, NULL) == TSK_OK);
    identity(world);
    world[3] = 0.3f;
    for (int b = 0; b < 4; ++b) {
        identity(pose + 16 * b);
        const double a = 0.3 * (b + 1);
        pose[16 * b + 5] = (float)cos(a), pose[16 * b + 6] = (float)-sin(a);
        pose[16 * b + 9] = (float)sin(a), pose[16 * b + 10] = (float)cos(a);
        pose[16 * b + 7] = 0.4f * b;
    }
    int32_t group[LEG_POINTS], spheres = 0;
    CHECK(tsk_collider_fit_bones(g.pts, LEG_POINTS, to_arm, g.heads, g.tails, g.rest, g.parent,
                                 g.deforms, 4, 0.05f, fit, group) == TSK_OK);
    CHECK(tsk_collider_fit_groups(g.pts, LEG_POINTS, NULL, 0, group, to_arm, world, pose, 4,
                                  rows) == TSK_OK);
    float srows[8 * 32];
    CHECK(tsk_collider_fit_spheres(g.pts, LEG_POINTS, NULL, 0, pose, 32, srows, &spheres) ==
          TSK_OK);
    uint64_t h = tsk_test_fnv(fit, sizeof fit, 1469598103934665603ull);
    h = tsk_test_fnv(rows, sizeof rows, h);
    h = tsk_test_fnv(group, sizeof group, h);
    h = tsk_test_fnv(srows, sizeof(float) * 8 * (size_t)spheres, h);
    printf("  collider golden 0x%016llx\n", (unsigned long long)h);
    CHECK(h == COLLIDER_GOLDEN);
}

TEST_MAIN(TEST_ENTRY(test_bone_capsules_are_the_limbs_cylinders),
          TEST_ENTRY(test_small_bones_give_their_points_to_their_parent),
          TEST_ENTRY(test_a_bone_at_an_angle_fits_along_its_own_axis),
          TEST_ENTRY(test_posed_capsules_are_the_rest_capsules_moved_by_the_pose),
          TEST_ENTRY(test_spheres_hold_every_face_of_a_cube),
          TEST_ENTRY(test_spheres_leave_the_open_corner_of_an_l_shape_open),
          TEST_ENTRY(test_mesh_volume_of_closed_meshes),
          TEST_ENTRY(test_bad_fit_inputs_are_refused),
          TEST_ENTRY(test_fits_give_the_same_bytes_everywhere))
