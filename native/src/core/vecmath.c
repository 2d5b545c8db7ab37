/* Small array math shared by modules and exercised through the Python binding. */
#include "tussock/core.h"

#include <math.h>

tsk_status tsk_vec3_lengths(const float* xyz, size_t count, float* out) {
    if (count > 0 && (xyz == NULL || out == NULL))
        return tsk_error_arg(TSK_ERR_ARGUMENT, xyz == NULL ? "xyz" : "out", "is NULL");
    for (size_t i = 0; i < count; ++i) {
        const float x = xyz[3 * i], y = xyz[3 * i + 1], z = xyz[3 * i + 2];
        if (!isfinite(x) || !isfinite(y) || !isfinite(z))
            return tsk_error_arg(TSK_ERR_ARGUMENT, "xyz", "vector %zu is not finite", i);
        out[i] = sqrtf(x * x + y * y + z * z);
    }
    return TSK_OK;
}
