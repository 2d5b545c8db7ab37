/* Fuzz target: pictures and masks. First byte chooses the entry:
 *  even: the rest is a picture file (PNG / JPEG / OpenEXR by its signature, else an unknown
 *        extension) for tsk_picture_load; a small loaded picture then gets a mask made of the
 *        following bytes;
 *  odd:  a small picture (4..24 px per side) of fuzzed float RGBA from the bytes, masks
 *        (u8 and f32, NaN included), GrabCut on a fuzzed rectangle, tsk_picture_build with a
 *        fuzzed tsk_layers_def, a layer frame with a fuzzed warp def and velocity field, and
 *        the composite. */
#include "fuzz.h"
#include "tussock/picture.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    return 0;
}

static void exercise(tsk_picture* p, fz* r) {
    int w = 0, h = 0;
    if (tsk_picture_size(p, &w, &h) != TSK_OK) abort();
    const size_t n = (size_t)w * (size_t)h;
    if (n > 64 * 64) return;
    float* rgba = malloc(n * 4 * sizeof *rgba);
    if (tsk_picture_read_rgba(p, rgba, n * 4, fz_u8(r) & 1) != TSK_OK) abort();
    uint8_t* mask = malloc(n);
    float* fmask = malloc(n * sizeof *fmask);
    const int layers = 1 + fz_u8(r) % 3;
    for (int l = 0; l < layers; ++l) {
        const int kind = fz_u8(r) % 3;
        if (kind == 0) { /* rectangle */
            const int x0 = fz_u8(r) % w, y0 = fz_u8(r) % h;
            const int x1 = x0 + fz_u8(r) % w, y1 = y0 + fz_u8(r) % h;
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    mask[(size_t)y * w + x] = (x >= x0 && x < x1 && y >= y0 && y < y1) ? 255 : 0;
            (void)tsk_picture_add_layer_u8(p, mask, n, NULL);
        } else if (kind == 1) { /* raw bytes */
            for (size_t i = 0; i < n; ++i) mask[i] = fz_u8(r);
            (void)tsk_picture_add_layer_u8(p, mask, n, NULL);
        } else { /* floats, NaN and all */
            for (size_t i = 0; i < n; ++i) fmask[i] = fz_float(r, (i % 3) ? 1.0f : 0.0f);
            (void)tsk_picture_add_layer_f32(p, fmask, n, NULL);
        }
    }
    (void)tsk_picture_add_layer_u8(p, mask, n - 1, NULL); /* wrong size */
    if (fz_u8(r) % 4 == 0) {
        tsk_grabcut_def g = tsk_default_grabcut_def();
        g.rect_x = fz_int(r, 1);
        g.rect_y = fz_int(r, 1);
        g.rect_width = fz_int(r, w - 2);
        g.rect_height = fz_int(r, h - 2);
        g.iterations = fz_int(r, 1);
        if (g.iterations > 2) g.iterations = 2; /* cost only */
        uint8_t* strokes = malloc(n);
        for (size_t i = 0; i < n; ++i) strokes[i] = fz_u8(r) % 4;
        (void)tsk_picture_propose_mask(p, &g, (fz_u8(r) & 1) ? strokes : NULL, n, mask, n);
        free(strokes);
    }
    tsk_layers_def ld = tsk_default_layers_def();
    ld.method = (tsk_inpaint_method)(fz_u8(r) % 3);
    ld.inpaint_radius = fz_float(r, ld.inpaint_radius);
    ld.grow = fz_float(r, ld.grow);
    ld.feather = fz_float(r, ld.feather);
    if (tsk_picture_build(p, &ld) == TSK_OK) {
        const int nl = tsk_picture_layer_count(p);
        float* out = malloc(n * 4 * sizeof *out);
        float* uv = malloc(n * 4 * sizeof *uv);
        for (int l = 0; l < nl; ++l) {
            if (tsk_picture_read_layer(p, l, out, n * 4, 0) != TSK_OK) abort();
            if (tsk_picture_read_matte(p, l, fmask, n, 1) != TSK_OK) abort();
            for (size_t i = 0; i < n; ++i)
                if (!(fmask[i] >= 0.0f && fmask[i] <= 1.0f)) abort();
        }
        if (tsk_picture_read_background(p, out, n * 4, 0) != TSK_OK) abort();
        tsk_warp_def wd = tsk_default_warp_def();
        wd.cell_x = fz_int(r, 4);
        wd.cell_y = fz_int(r, 4);
        wd.lambda_x = fz_float(r, 4.0f);
        wd.lambda_y = fz_float(r, 4.0f);
        wd.dt = fz_float(r, wd.dt);
        wd.rigidity = fz_float(r, 1.0f);
        wd.root = (tsk_picture_root)(fz_u8(r) % 4);
        wd.auto_root = fz_u8(r) % 3;
        wd.root_y = fz_float(r, (float)h);
        wd.height = fz_float(r, (float)h);
        wd.sampling = (tsk_warp_sampling)(fz_u8(r) % 3);
        float vx[16], vy[16];
        for (int i = 0; i < 16; ++i) {
            vx[i] = fz_float(r, 0.5f);
            vy[i] = fz_float(r, -0.25f);
        }
        tsk_picture_field field = {vx, vy, 1 + fz_u8(r) % 4, 1 + fz_u8(r) % 4, fz_u8(r) & 1};
        if (fz_u8(r) % 5 == 0) { /* invalid widths only: valid ones must fit the 16 values */
            field.width = fz_int(r, 4);
            if (field.width >= 1 && field.width <= 4096) field.width = 16 / field.height;
        }
        float* scale = malloc(n * sizeof *scale);
        for (size_t i = 0; i < n; ++i) scale[i] = fz_float(r, 1.0f);
        const int use_scale = fz_u8(r) & 1;
        const int layer = nl > 0 ? fz_u8(r) % (nl + 1) : 0;
        (void)tsk_picture_layer_frame(p, layer, &wd, &field, use_scale ? scale : NULL,
                                      use_scale ? n : 0, out, n * 4, uv, n * 4, fz_u8(r) & 1);
        const float* lp[TSK_PICTURE_MAX_LAYERS] = {0};
        if (nl > 0) lp[0] = out;
        (void)tsk_picture_composite(p, lp, (size_t)nl, uv, n * 4);
        free(scale);
        free(out);
        free(uv);
    }
    free(mask);
    free(fmask);
    free(rgba);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1 || size > (1u << 20)) return 0;
    fz r = {data + 1, size - 1};
    tsk_picture* p = NULL;
    if ((data[0] & 1) == 0) {
        const char* ext = "bin";
        if (size >= 2 && data[1] == 0x89) ext = "png";
        else if (size >= 3 && data[1] == 0xff && data[2] == 0xd8) ext = "jpg";
        else if (size >= 2 && data[1] == 0x76) ext = "exr";
        char path[128];
        if (!fz_write_temp(data + 1, size - 1, ext, path, sizeof path)) return 0;
        const tsk_status s = tsk_picture_load(path, &p);
        unlink(path);
        if (s != TSK_OK && p != NULL) abort();
        /* the masks of a loaded picture come from the file's last bytes */
        fz tail = {data + size / 2, size - size / 2};
        if (p != NULL) exercise(p, &tail);
    } else {
        const int w = 4 + fz_u8(&r) % 21, h = 4 + fz_u8(&r) % 21;
        const size_t n = (size_t)w * h * 4;
        float* rgba = malloc(n * sizeof *rgba);
        for (size_t i = 0; i < n; ++i)
            rgba[i] = (fz_u8(&r) % 32 == 0) ? fz_float(&r, 0.5f) : (float)fz_u8(&r) / 255.0f;
        const int bw = (fz_u8(&r) % 8 == 0) ? fz_int(&r, w) : w;
        if (tsk_picture_create(bw, h, rgba, n, fz_u8(&r) & 1, &p) != TSK_OK && p != NULL) abort();
        free(rgba);
        if (p != NULL) exercise(p, &r);
    }
    tsk_picture_destroy(p);
    fz_check_leaks("picture");
    return 0;
}
