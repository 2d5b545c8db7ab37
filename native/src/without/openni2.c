/* Stand-in for the OpenNI2 back end (capture/depth_openni.c) in a build without OpenNI2 (CMake
 * option TSK_WITH_OPENNI2=OFF): opening a device or a recording fails with a message that says
 * so. A recording still goes through the recording reader process (capture/depth_oni_proxy.c),
 * whose own copy of this file gives the answer. */
#include "capture/depth_internal.h"

tsk_status tsk_oni_open(tsk_depth_source* src, const char* uri, int is_file) {
    (void)src, (void)uri;
    return tsk_error(TSK_ERR_INTERNAL, "%s: this Tussock was built without OpenNI2",
                     is_file ? "reading an OpenNI2 recording" : "opening a depth camera");
}

/* never reached: no source gets OpenNI2 state without tsk_oni_open */
static tsk_status without_openni2(void) {
    return tsk_error(TSK_ERR_INTERNAL, "this Tussock was built without OpenNI2");
}
tsk_status tsk_oni_start(tsk_depth_source* src) {
    (void)src;
    return without_openni2();
}
tsk_status tsk_oni_stop(tsk_depth_source* src) {
    (void)src;
    return without_openni2();
}
tsk_status tsk_oni_seek(tsk_depth_source* src, int index) {
    (void)src, (void)index;
    return without_openni2();
}
tsk_status tsk_oni_read(tsk_depth_source* src, float* depth_m, size_t count,
                        tsk_depth_frame* frame) {
    (void)src, (void)depth_m, (void)count, (void)frame;
    return without_openni2();
}
void tsk_oni_close(tsk_depth_source* src) { (void)src; }
void tsk_oni_simulate_loss(tsk_depth_source* src) { (void)src; }
