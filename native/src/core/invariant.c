/* The failure end of TSK_ASSERT (core/invariant.h). */
#include "core/invariant.h"

#include <stdio.h>
#include <stdlib.h>

#if TSK_ASSERTS_ON
void tsk_assert_fail(const char* cond, const char* file, int line, const char* func) {
    fprintf(stderr, "%s:%d: %s: Tussock invariant failed: %s\n", file, line, func, cond);
    fflush(stderr);
    abort();
}
#else
typedef int tsk_no_asserts; /* not an empty translation unit */
#endif
