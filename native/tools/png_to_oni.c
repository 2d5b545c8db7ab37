/* png_to_oni: writes a depth image sequence as an OpenNI2 recording (.oni), so that a
 * capture from the recording can be compared with a capture from the images.
 *
 *     png_to_oni OUT.oni PATTERN        e.g. png_to_oni blades.oni samples/blades/depth_####.png
 *
 * The frames are read through Tussock's own depth-file source (tsk_depth_open_files: 16-bit
 * PNG in millimetres or float EXR in metres, '#' for the frame number) and written, in
 * millimetres, by the test-only writer native/tests/oni_writer.h. The recording carries the
 * field of view that gives back the source's intrinsics: OpenNI2 reports it as float
 * radians and Tussock turns it into fx = (width/2) / tan(hfov/2) (tsk_intrinsics_from_fov),
 * so the float field of view is chosen, among the neighbours of 2 atan((width/2) / fx), as
 * the one that gives fx (and fy) back exactly where one does. The principal point of a
 * recording is always the image centre, as it is for depth files.
 *
 * The recording is then played back through tsk_depth_open_oni (the reader process that
 * Tussock uses, found beside this program or at $TSK_ONI_READER) and checked: the same
 * number of frames, the same intrinsics, the same depth in every pixel. Any failure prints a
 * message, removes the output and exits with 1. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tussock/capture.h"
#include "tussock/core.h"
#include "oni_writer.h"

#define ULP_SEARCH 64 /* neighbours of the field of view tried on either side */

static const char* g_out = NULL; /* removed on failure once writing has started */

static int fail(const char* fmt, ...)
#if defined(__MINGW32__) /* formats with MinGW's C99 printf, as the library does */
    __attribute__((format(gnu_printf, 1, 2)))
#elif defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;
static int fail(const char* fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "png_to_oni: ");
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n");
    va_end(ap);
    if (g_out != NULL) remove(g_out);
    return 1;
}

static const char* last_error(void) {
    const char* m = tsk_last_error();
    return (m != NULL && m[0] != '\0') ? m : "unknown error";
}

/* The focal length in pixels that Tussock derives from a field of view `fov` over `side`
 * pixels (the same code a recording's reader runs). */
static float focal_of(int side, float fov) {
    tsk_intrinsics k;
    if (tsk_intrinsics_from_fov(side, side, fov, fov, &k) != TSK_OK) return NAN;
    return k.fx;
}

/* The float field of view over `side` pixels whose focal length is closest to `f`
 * (exactly `f` where a float gives it). */
static float fit_fov(int side, float f) {
    float best = (float)(2.0 * atan(0.5 * (double)side / (double)f));
    float best_err = fabsf(focal_of(side, best) - f);
    float lo = best, hi = best;
    for (int i = 0; i < ULP_SEARCH && best_err > 0.0f; ++i) {
        lo = nextafterf(lo, 0.0f);
        hi = nextafterf(hi, 4.0f);
        const float cand[2] = {lo, hi};
        for (int c = 0; c < 2; ++c) {
            const float err = fabsf(focal_of(side, cand[c]) - f);
            if (err < best_err) best = cand[c], best_err = err;
        }
    }
    return best;
}

/* Plays the written recording back and compares it with the source, frame by frame. */
static int verify(const char* out, tsk_depth_source* files, const tsk_depth_info* want, int frames,
                  float* a, float* b, size_t count) {
    tsk_depth_source* oni = NULL;
    if (tsk_depth_open_oni(out, &oni) != TSK_OK)
        return fail("the recording written to '%s' does not open: %s", out, last_error());
    tsk_depth_info got;
    int rc = 0;
    if (tsk_depth_get_info(oni, &got) != TSK_OK) {
        rc = fail("cannot describe the recording '%s': %s", out, last_error());
    } else if (got.width != want->width || got.height != want->height ||
               got.frame_count != frames) {
        rc = fail("the recording '%s' plays %d frames of %dx%d, not %d of %dx%d", out,
                  got.frame_count, got.width, got.height, frames, want->width, want->height);
    } else if (!got.has_device_intrinsics) {
        rc = fail("the recording '%s' reports no field of view", out);
    }
    if (rc == 0 && tsk_depth_seek(files, 0) != TSK_OK)
        rc = fail("cannot rewind '%s': %s", want->description, last_error());
    size_t differ = 0;
    for (int i = 0; rc == 0 && i < frames; ++i) {
        tsk_depth_frame fa, fb;
        if (tsk_depth_read(files, a, count, &fa) != TSK_OK || !fa.is_new) {
            rc = fail("cannot read frame %d of '%s' again: %s", i, want->description, last_error());
        } else if (tsk_depth_read(oni, b, count, &fb) != TSK_OK || !fb.is_new) {
            rc = fail("the recording '%s' does not play frame %d: %s", out, i, last_error());
        } else {
            for (size_t k = 0; k < count; ++k) differ += a[k] != b[k];
        }
    }
    tsk_depth_close(oni);
    if (rc != 0) return rc;
    if (differ != 0)
        return fail("the recording '%s' plays %zu depth values that differ from the images", out,
                    differ);
    printf(
        "png_to_oni: played back through the recording reader: %d frames, every depth "
        "value equal; intrinsics fx %.9g fy %.9g cx %.9g cy %.9g px (images: fx %.9g fy "
        "%.9g cx %.9g cy %.9g)\n",
        frames, got.intrinsics.fx, got.intrinsics.fy, got.intrinsics.cx, got.intrinsics.cy,
        want->intrinsics.fx, want->intrinsics.fy, want->intrinsics.cx, want->intrinsics.cy);
    if (memcmp(&got.intrinsics, &want->intrinsics, sizeof got.intrinsics) != 0)
        printf(
            "png_to_oni: note: the recording's intrinsics differ from the images' in the "
            "last bits (no float field of view gives them exactly with this libm's tanf): captures "
            "agree to rounding, not bit for bit\n");
    return 0;
}

static int convert(const char* out, const char* pattern) {
    tsk_depth_source* src = NULL;
    if (tsk_depth_open_files(pattern, &src) != TSK_OK)
        return fail("cannot open the depth images '%s': %s", pattern, last_error());
    tsk_depth_info info;
    if (tsk_depth_get_info(src, &info) != TSK_OK) {
        tsk_depth_close(src);
        return fail("cannot describe '%s': %s", pattern, last_error());
    }
    const int w = info.width, h = info.height;
    const tsk_intrinsics k = info.intrinsics;
    if (k.cx != 0.5f * (float)(w - 1) || k.cy != 0.5f * (float)(h - 1))
        fprintf(stderr,
                "png_to_oni: warning: principal point (%g, %g) is not the image centre; a "
                "recording cannot carry it\n",
                k.cx, k.cy);
    const float hfov = fit_fov(w, k.fx), vfov = fit_fov(h, k.fy);
    const size_t count = (size_t)w * (size_t)h;
    float* depth = malloc(count * sizeof *depth);
    float* again = malloc(count * sizeof *again);
    uint16_t* mm = malloc(count * sizeof *mm);
    int rc = 0;
    if (depth == NULL || again == NULL || mm == NULL) {
        rc = fail("out of memory for %dx%d frames", w, h);
        goto done;
    }
    oni_writer ow;
    /* the writer stores the field of view as doubles; OpenNI2 reports it as float */
    if (oniw_open(&ow, out, w, h, (double)hfov, (double)vfov) != 0) {
        rc = fail("cannot write '%s': %s", out, strerror(errno));
        goto done;
    }
    g_out = out;
    int frames = 0;
    size_t clamped = 0;
    for (;;) {
        tsk_depth_frame fr;
        if (tsk_depth_read(src, depth, count, &fr) != TSK_OK) {
            oniw_close(&ow);
            rc = fail("cannot read frame %d of '%s': %s", frames, pattern, last_error());
            goto done;
        }
        if (!fr.is_new) break;
        for (size_t i = 0; i < count; ++i) {
            const float v = roundf(depth[i] * 1000.0f); /* metres -> millimetres */
            clamped += v > 65535.0f;
            mm[i] = (uint16_t)(v > 65535.0f ? 65535.0f : v);
        }
        if (oniw_frame(&ow, mm) != 0) {
            oniw_close(&ow);
            rc = fail("out of memory writing frame %d", frames);
            goto done;
        }
        ++frames;
        if (fr.end) break;
    }
    const int write_error = ferror(ow.f);
    if (oniw_close(&ow) != 0 || write_error) {
        rc = fail("cannot write '%s': %s", out, write_error ? "write error" : strerror(errno));
        goto done;
    }
    if (frames == 0) {
        rc = fail("'%s' gave no frame", pattern);
        goto done;
    }
    printf(
        "png_to_oni: wrote %d frames of %dx%d from '%s' to '%s'; field of view %.9g x %.9g "
        "rad, which gives fx %.9g, fy %.9g px (the images': %.9g, %.9g)\n",
        frames, w, h, info.description, out, hfov, vfov, focal_of(w, hfov), focal_of(h, vfov), k.fx,
        k.fy);
    if (clamped)
        printf("png_to_oni: note: %zu depth values beyond 65.535 m were written as 65535 mm\n",
               clamped);
    rc = verify(out, src, &info, frames, depth, again, count);
done:
    free(depth);
    free(again);
    free(mm);
    tsk_depth_close(src);
    return rc;
}

int main(int argc, char** argv) {
    if (argc != 3 || argv[1][0] == '\0' || argv[2][0] == '\0') {
        fprintf(stderr,
                "usage: %s OUT.oni PATTERN\n"
                "  writes the depth images PATTERN (e.g. samples/blades/depth_####.png) as an\n"
                "  OpenNI2 recording OUT.oni and checks that it plays back the same depth\n",
                argc > 0 ? argv[0] : "png_to_oni");
        return 1;
    }
    return convert(argv[1], argv[2]);
}
