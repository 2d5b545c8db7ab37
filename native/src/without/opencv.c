/* Stand-in for the OpenCV bridges (bridge/opencv_capture.cpp, bridge/opencv_picture.cpp) in a
 * build without OpenCV (CMake option TSK_WITH_OPENCV=OFF): every function fails with a message
 * that says so, and writes nothing a caller could mistake for a result. */
#include "bridge/opencv_capture_bridge.h"
#include "bridge/opencv_picture_bridge.h"

static tsk_status without_opencv(const char* what) {
    return tsk_error(TSK_ERR_INTERNAL, "%s: this Tussock was built without OpenCV", what);
}

tsk_status tsk_cvb_read_depth(const char* path, int* width, int* height, tsk_cvb_depth_type* type,
                              void** data) {
    (void)path, (void)width, (void)height, (void)type;
    *data = NULL;
    return without_opencv("decoding a depth image");
}

tsk_status tsk_cvb_write_png16(const char* path, const uint16_t* data, int width, int height) {
    (void)path, (void)data, (void)width, (void)height;
    return without_opencv("writing a PNG");
}

tsk_status tsk_cvb_write_exr(const char* path, const float* data, int width, int height) {
    (void)path, (void)data, (void)width, (void)height;
    return without_opencv("writing an OpenEXR file");
}

tsk_status tsk_cvb_write_png8(const char* path, const uint8_t* data, int width, int height,
                              int channels) {
    (void)path, (void)data, (void)width, (void)height, (void)channels;
    return without_opencv("writing a PNG");
}

tsk_status tsk_cvb_morphology(uint8_t* mask, int width, int height, int close_radius,
                              int open_radius) {
    (void)mask, (void)width, (void)height, (void)close_radius, (void)open_radius;
    return without_opencv("cleaning the depth mask");
}

tsk_status tsk_cvb_find_contours(const uint8_t* mask, int width, int height, double min_area,
                                 tsk_cvb_contours* out) {
    (void)mask, (void)width, (void)height, (void)min_area;
    out->count = 0, out->start = NULL, out->xy = NULL, out->area = NULL;
    return without_opencv("finding contours");
}

void tsk_cvb_contours_free(tsk_cvb_contours* c) {
    if (c == NULL) return;
    tsk_free(c->start), tsk_free(c->xy), tsk_free(c->area);
    c->count = 0, c->start = NULL, c->xy = NULL, c->area = NULL;
}

tsk_status tsk_cvb_fill_poly(uint8_t* img, int width, int height, const float* xy, int n,
                             uint8_t value) {
    (void)img, (void)width, (void)height, (void)xy, (void)n, (void)value;
    return without_opencv("filling a polygon");
}

tsk_status tsk_cvb_polyline(uint8_t* img, int width, int height, const float* xy, int n,
                            uint8_t value) {
    (void)img, (void)width, (void)height, (void)xy, (void)n, (void)value;
    return without_opencv("drawing a polyline");
}

void tsk_cvb_set_threads(int threads) { (void)threads; }

tsk_status tsk_cvp_decode(const char* path, int width, int height, float* rgba) {
    (void)path, (void)width, (void)height, (void)rgba;
    return without_opencv("decoding an image");
}

tsk_status tsk_cvp_grabcut(const float* rgba, int width, int height, int rx, int ry, int rw, int rh,
                           int iterations, const uint8_t* strokes, uint8_t* mask) {
    (void)rgba, (void)width, (void)height, (void)rx, (void)ry, (void)rw, (void)rh;
    (void)iterations, (void)strokes, (void)mask;
    return without_opencv("segmenting the picture (GrabCut)");
}

tsk_status tsk_cvp_inpaint(float* rgba, int width, int height, const uint8_t* region, float radius,
                           int method, int channels) {
    (void)rgba, (void)width, (void)height, (void)region, (void)radius, (void)method;
    (void)channels;
    return without_opencv("inpainting");
}

tsk_status tsk_cvp_distances(const uint8_t* mask, int width, int height, float* inside,
                             float* outside) {
    (void)mask, (void)width, (void)height, (void)inside, (void)outside;
    return without_opencv("distance transforms");
}

tsk_status tsk_cvp_remap(const float* src, int width, int height, const float* map_x,
                         const float* map_y, float* dst, int threads) {
    (void)src, (void)width, (void)height, (void)map_x, (void)map_y, (void)dst, (void)threads;
    return without_opencv("cv::remap");
}

tsk_status tsk_cvp_encode(const char* path, const float* rgba, int width, int height, int channels,
                          int bits) {
    (void)path, (void)rgba, (void)width, (void)height, (void)channels, (void)bits;
    return without_opencv("writing an image");
}

tsk_status tsk_cvp_write_exr(const char* path, const float* rgba, int width, int height) {
    (void)path, (void)rgba, (void)width, (void)height;
    return without_opencv("writing an OpenEXR file");
}
