/* Private layout of a picture handle shared by the picture module's files. */
#ifndef TSK_PICTURE_INTERNAL_H
#define TSK_PICTURE_INTERNAL_H

#include "tussock/picture.h"

typedef struct tsk_picture_layer {
    uint8_t* mask; /* W*H, 1 = vegetation */
    float* matte; /* W*H, 0..1 (built) */
    float* rgba; /* 4*W*H premultiplied colour at rest (built) */
    int box_x0, box_y0, box_x1, box_y1; /* mask bounding box, pixels, [x0, x1) x [y0, y1) */
} tsk_picture_layer;

struct tsk_picture {
    int width, height;
    float* rgba; /* 4*W*H straight, top-first */
    float* background; /* 4*W*H premultiplied (built) */
    int layer_count;
    int built;
    tsk_picture_layer layers[TSK_PICTURE_MAX_LAYERS];
};

/* Reads a picture file's width and height from its header (PNG, JPEG, EXR). */
tsk_status tsk_picture_header_size(const uint8_t* bytes, size_t size, const char* name, int* width,
                                   int* height);

/* Checks W and H against min_side and the limits; `arg` names the argument in the message. */
tsk_status tsk_picture_check_size(int width, int height, int min_side, const char* arg);

/* Copies rows of 4-float pixels, flipping them when `flip`. */
void tsk_picture_copy_rows(float* dst, const float* src, int width, int height, int channels,
                           int flip);

/* Samples src (premultiplied RGBA, top-first) through a UV pass (bottom-up rows, RGBA) the
 * way Blender 3.x's compositor Map UV node does (EWA); dst top-first. */
void tsk_picture_map_uv(int width, int height, const float* src, const float* uv_bottom_up,
                        float* dst);

/* As tsk_picture_map_uv, the way Blender 5.x's Map UV node does with Interpolation
 * "Anisotropic" on the CPU: derivatives across 2x2 pixel blocks, the sample multiplied by
 * the UV pass's third channel. */
void tsk_picture_map_uv_5(int width, int height, const float* src, const float* uv_bottom_up,
                          float* dst);

#endif
