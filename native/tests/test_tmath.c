/* Tests of core/tmath.c: the elementary functions whose bits must not depend on the system.
 * - Against glibc's double functions (accurate to an ulp of a double, so their value rounded
 *   to float is the correctly rounded float but within 2^-40 of a float's rounding boundary):
 *   millions of inputs of every size, the large ones through the Payne-Hanek reduction.
 * - Against exact expectations everywhere: Annex F's special values, fmaf's double-rounding
 *   cases, and one golden hash of every function's output on a fixed set of inputs, which a
 *   Windows build must reproduce bit for bit. */
#include "test.h"
#include "core/tmath.h"

#include <float.h>

static const double PI = 3.14159265358979323846;

/* xorshift64*: the inputs, the same on every system */
static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static uint64_t next_u64(void) {
    rng_state ^= rng_state >> 12, rng_state ^= rng_state << 25, rng_state ^= rng_state >> 27;
    return rng_state * 2685821657736338717ull;
}
static uint32_t bits_of_float(float f) {
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    return b;
}
/* a finite float of either sign with |x| in [2^lo, 2^hi) (log-uniform) */
static float any_float(int lo, int hi) {
    const uint64_t r = next_u64();
    const int e = lo + (int)((r >> 32) % (uint64_t)(hi - lo));
    const float m = 1.0f + (float)(r & 0x7fffff) * 0x1p-23f;
    const float x = ldexpf(m, e);
    return (r >> 63) ? -x : x;
}
static float uniform(float a, float b) {
    return a + (b - a) * (float)(next_u64() >> 40) * 0x1p-24f;
}

static int same_float(float a, float b) {
    return (isnan(a) && isnan(b)) || bits_of_float(a) == bits_of_float(b);
}

#ifdef __GLIBC__
/* 1 if the double ref is within 2^-40 (relative) of a point halfway between two floats,
 * where an ulp of error in the reference may round either way */
static int near_midpoint(double ref) {
    if (!isfinite(ref) || ref == 0.0) return 0;
    const float f = (float)ref;
    if (isinf(f)) return 0;
    const double up = 0.5 * ((double)f + (double)nextafterf(f, INFINITY));
    const double down = 0.5 * ((double)f + (double)nextafterf(f, -INFINITY));
    const double d = fmin(fabs(ref - up), fabs(ref - down));
    return d <= fabs(ref) * 0x1p-40;
}

typedef struct {
    long checked, hard, wrong;
    float x, y, got, want; /* the first wrong one */
} tally;

static void compare(tally* t, float x, float y, float got, double ref) {
    ++t->checked;
    const float want = (float)ref;
    if (same_float(got, want)) return;
    if (near_midpoint(ref)) {
        ++t->hard;
        return;
    }
    if (t->wrong++ == 0) t->x = x, t->y = y, t->got = got, t->want = want;
}

static void report(const char* name, const tally* t) {
    CHECK_MSG(t->wrong == 0,
              "%s: %ld of %ld differ from glibc's double rounded to float, first at x = %a "
              "(y = %a): %a, not %a",
              name, t->wrong, t->checked, (double)t->x, (double)t->y, (double)t->got,
              (double)t->want);
    CHECK_MSG(t->hard * 100000 <= t->checked, "%s: %ld hard cases in %ld", name, t->hard,
              t->checked);
}

TEST(test_float_functions_are_glibc_doubles_rounded) {
    enum { N = 1 << 22 };
    tally ts = {0}, tc = {0}, tt = {0}, te = {0}, tp = {0}, ta = {0}, t2 = {0}, th = {0};
    for (int i = 0; i < N; ++i) {
        /* trigonometry: every size up to FLT_MAX, and the phases of ordinary angles */
        const float x = (i & 1) ? any_float(-30, 128) : uniform(-20.0f, 20.0f);
        float s, c;
        tsk_sincosf(x, &s, &c);
        compare(&ts, x, 0, tsk_sinf(x), sin((double)x));
        compare(&tc, x, 0, tsk_cosf(x), cos((double)x));
        compare(&ts, x, 0, s, sin((double)x));
        compare(&tc, x, 0, c, cos((double)x));
        compare(&tt, x, 0, tsk_tanf(x), tan((double)x));
        const float ex = (i & 1) ? any_float(-40, 7) : uniform(-110.0f, 95.0f);
        compare(&te, ex, 0, tsk_expf(ex), exp((double)ex));
        /* powers: bases of every size, exponents as the tree's and the wind's (and larger),
         * integers for negative bases */
        float px = any_float(-30, 30), py = uniform(-12.0f, 12.0f);
        if (i % 4 == 0) py = floorf(py);
        else px = fabsf(px);
        compare(&tp, px, py, tsk_powf(px, py), pow((double)px, (double)py));
        const float ax = (i & 1) ? uniform(-1.0f, 1.0f) : copysignf(1.0f - any_float(-24, -1), x);
        compare(&ta, ax, 0, tsk_acosf(ax), acos((double)ax));
        const float ay = any_float(-20, 20), bx = any_float(-20, 20);
        compare(&t2, ay, bx, tsk_atan2f(ay, bx), atan2((double)ay, (double)bx));
        const float hx = any_float(-70, 70), hy = any_float(-70, 70);
        ++th.checked; /* glibc's hypotf is the same double computation: equal bits */
        if (!same_float(tsk_hypotf(hx, hy), hypotf(hx, hy)) && th.wrong++ == 0)
            th.x = hx, th.y = hy, th.got = tsk_hypotf(hx, hy), th.want = hypotf(hx, hy);
    }
    report("sinf", &ts), report("cosf", &tc), report("tanf", &tt), report("expf", &te);
    report("powf", &tp), report("acosf", &ta), report("atan2f", &t2), report("hypotf", &th);
}

/* The double functions within 2 ulp of glibc's (which are within 1) where they promise it. */
TEST(test_double_functions_are_within_two_ulp) {
    double worst[5] = {0};
    for (int i = 0; i < (1 << 19); ++i) {
        const double x = (double)uniform(-1e6f, 1e6f) + (double)uniform(-1, 1) * 0x1p-30;
        const double e = (double)uniform(-740.0f, 705.0f) * (1.0 + 0x1p-40);
        const double y = (double)any_float(-40, 40), z = (double)any_float(-40, 40);
        const double got[5] = {tsk_sin(x), tsk_cos(x), tsk_exp(e), tsk_atan(y), tsk_atan2(y, z)};
        const double want[5] = {sin(x), cos(x), exp(e), atan(y), atan2(y, z)};
        for (int k = 0; k < 5; ++k) {
            if (want[k] == 0.0 || !isfinite(want[k])) continue;
            /* in units of the last place of the reference */
            const double ulp = nextafter(fabs(want[k]), INFINITY) - fabs(want[k]);
            worst[k] = fmax(worst[k], fabs(got[k] - want[k]) / ulp);
        }
    }
    static const char* names[5] = {"sin", "cos", "exp", "atan", "atan2"};
    for (int k = 0; k < 5; ++k)
        CHECK_MSG(worst[k] <= 2.0, "%s: %.2f ulp from glibc's", names[k], worst[k]);
}

/* tsk_fmaf_exact against glibc's fmaf (exact): products that cancel, sums at a midpoint */
TEST(test_fmaf_exact_is_glibc_fmaf) {
    long wrong = 0;
    for (int i = 0; i < (1 << 21); ++i) {
        const float a = any_float(-60, 60), b = any_float(-60, 60);
        float c = any_float(-120, 120);
        if (i % 3 == 0) c = -a * b * (1.0f + uniform(-1e-6f, 1e-6f)); /* cancellation */
        if (i % 3 == 1) c = (float)((double)a * b) * uniform(1.0f, 3.0f);
        if (!same_float(tsk_fmaf_exact(a, b, c), fmaf(a, b, c)) && wrong++ == 0)
            fprintf(stderr, "  fmaf(%a, %a, %a): %a, glibc %a\n", (double)a, (double)b, (double)c,
                    (double)tsk_fmaf_exact(a, b, c), (double)fmaf(a, b, c));
    }
    CHECK_MSG(wrong == 0, "%ld results differ from glibc's fmaf", wrong);
}
#endif

/* The sums that round twice in double then float: exact below a midpoint of two floats whose
 * lower one is odd (ties-to-even would go up), and above one whose lower is even. */
TEST(test_fmaf_exact_rounds_once) {
    const float a = 1.0f + 0x1p-15f, b_below = 0x1p-24f * (1.0f - 0x1p-15f),
                b_above = 0x1p-24f * (1.0f + 0x1p-15f);
    /* a b = 2^-24 (1 - 2^-30): 1 + 2^-23 + a b lies just below the midpoint */
    CHECK(tsk_fmaf_exact(a, b_below, 1.0f + 0x1p-23f) == 1.0f + 0x1p-23f);
    CHECK(tsk_fmaf_exact(-a, b_below, -1.0f - 0x1p-23f) == -1.0f - 0x1p-23f);
    /* a b = 2^-24 (1 + 2^-14 + 2^-30): above the midpoint of 1 and 1 + 2^-23 */
    CHECK(tsk_fmaf_exact(a, b_above, 1.0f) == 1.0f + 0x1p-23f);
    /* exact results and signed zeros */
    CHECK(tsk_fmaf_exact(3.0f, 5.0f, -15.0f) == 0.0f && !signbit(tsk_fmaf_exact(3, 5, -15)));
    CHECK(signbit(tsk_fmaf_exact(-0.0f, 1.0f, -0.0f)));
    CHECK(tsk_fmaf_exact(0x1p-74f, 0x1p-75f, 0.0f) == 0x1p-149f); /* into the subnormals */
    CHECK(tsk_fmaf_exact(0x1p-75f, 0x1p-75f, 0.0f) == 0.0f); /* half of it: to even */
    CHECK(isinf(tsk_fmaf_exact(FLT_MAX, 2.0f, 0.0f)));
    CHECK(tsk_fmaf_exact(FLT_MAX, 1.0f, 0x1p103f * (1.0f - 0x1p-20f)) == FLT_MAX);
    CHECK(isnan(tsk_fmaf_exact(INFINITY, 0.0f, 1.0f)));
    CHECK(tsk_fmaf(2.0f, 3.0f, 1.0f) == 7.0f);
}

TEST(test_special_values_follow_annex_f) {
    CHECK(same_float(tsk_sinf(-0.0f), -0.0f) && tsk_cosf(0.0f) == 1.0f);
    CHECK(isnan(tsk_sinf(INFINITY)) && isnan(tsk_cosf(-INFINITY)) && isnan(tsk_tanf(NAN)));
    CHECK(tsk_expf(-INFINITY) == 0.0f && isinf(tsk_expf(INFINITY)) && isinf(tsk_expf(89.0f)));
    CHECK(tsk_expf(-104.0f) == 0.0f && tsk_expf(-100.0f) > 0.0f && tsk_expf(0.0f) == 1.0f);
    CHECK(tsk_acosf(1.0f) == 0.0f && tsk_acosf(-1.0f) == (float)PI);
    CHECK(isnan(tsk_acosf(1.0f + 0x1p-23f)) && isnan(tsk_acosf(NAN)));
    CHECK(tsk_powf(NAN, 0.0f) == 1.0f && tsk_powf(1.0f, NAN) == 1.0f);
    CHECK(isnan(tsk_powf(-2.0f, 0.5f)) && isnan(tsk_powf(NAN, 2.0f)));
    CHECK(same_float(tsk_powf(-0.0f, 3.0f), -0.0f) && same_float(tsk_powf(-0.0f, 2.0f), 0.0f));
    CHECK(tsk_powf(-0.0f, -3.0f) == -INFINITY && tsk_powf(-0.0f, -2.0f) == INFINITY);
    CHECK(tsk_powf(-1.0f, INFINITY) == 1.0f && tsk_powf(0.5f, -INFINITY) == INFINITY);
    CHECK(tsk_powf(2.0f, -INFINITY) == 0.0f && tsk_powf(0.5f, INFINITY) == 0.0f);
    CHECK(tsk_powf(-INFINITY, 3.0f) == -INFINITY && tsk_powf(-INFINITY, 2.0f) == INFINITY);
    CHECK(same_float(tsk_powf(-INFINITY, -3.0f), -0.0f) && tsk_powf(INFINITY, -1.0f) == 0.0f);
    CHECK(tsk_powf(-2.0f, 3.0f) == -8.0f && tsk_powf(2.0f, 10.0f) == 1024.0f);
    CHECK(tsk_powf(10.0f, 39.0f) == INFINITY && tsk_powf(10.0f, -46.0f) == 0.0f);
    CHECK(same_float(tsk_atan2f(-0.0f, 1.0f), -0.0f) && tsk_atan2f(0.0f, -1.0f) == (float)PI);
    CHECK(tsk_atan2f(-0.0f, -0.0f) == -(float)PI && tsk_atan2f(1.0f, 0.0f) == (float)(0.5 * PI));
    CHECK(tsk_atan2f(INFINITY, -INFINITY) == (float)(0.75 * PI));
    CHECK(isinf(tsk_hypotf(INFINITY, NAN)) && isnan(tsk_hypotf(NAN, 1.0f)));
    CHECK(tsk_hypotf(3.0f, 4.0f) == 5.0f);
}

/* Every function's bits on a fixed set of inputs: the same on every system (the Windows
 * build runs this under wine). A change of the implementation changes this hash; update it
 * with the reason in the commit. */
static const uint64_t TMATH_GOLDEN = 0x8c3ee9e87104a1a4ull;

TEST(test_bits_are_the_same_on_every_system) {
    rng_state = 0x243f6a8885a308d3ull;
    uint64_t h = TSK_TEST_FNV_START;
    for (int i = 0; i < (1 << 16); ++i) {
        const float x = (i & 1) ? any_float(-30, 128) : uniform(-20.0f, 20.0f);
        const float y = uniform(-8.0f, 8.0f), z = any_float(-40, 40);
        float out[12];
        tsk_sincosf(x, &out[0], &out[1]);
        out[2] = tsk_tanf(x), out[3] = tsk_expf(uniform(-100.0f, 80.0f));
        out[4] = tsk_powf(fabsf(z), y), out[5] = tsk_acosf(uniform(-1.0f, 1.0f));
        out[6] = tsk_atan2f(x, z), out[7] = tsk_hypotf(x, z);
        out[8] = tsk_fmaf_exact(x, z, y);
        out[9] = (float)tsk_sin((double)x * 0.7), out[10] = (float)tsk_exp((double)y * 3.3);
        out[11] = (float)tsk_atan((double)z);
        const double d[2] = {tsk_cos((double)x * 1.3), tsk_atan2((double)x, (double)z)};
        h = tsk_test_fnv(out, sizeof out, h);
        h = tsk_test_fnv(d, sizeof d, h);
    }
    CHECK_MSG(h == TMATH_GOLDEN, "the functions' bits changed: hash %#018llx",
              (unsigned long long)h);
}

#ifdef __GLIBC__
#define TEST_GLIBC(name) TEST_ENTRY(name)
#else
#define TEST_GLIBC(name) \
    { #name, NULL, "compares with glibc" }
#endif

TEST_MAIN(TEST_GLIBC(test_float_functions_are_glibc_doubles_rounded),
          TEST_GLIBC(test_double_functions_are_within_two_ulp),
          TEST_GLIBC(test_fmaf_exact_is_glibc_fmaf), TEST_ENTRY(test_fmaf_exact_rounds_once),
          TEST_ENTRY(test_special_values_follow_annex_f),
          TEST_ENTRY(test_bits_are_the_same_on_every_system))
