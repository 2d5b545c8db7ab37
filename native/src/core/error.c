/* Status names and the thread-local last-error message (DESIGN.md, "Errors"). */
#include "tussock/core.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

enum { TSK_ERROR_CAPACITY = 1024 };

static _Thread_local char g_message[TSK_ERROR_CAPACITY];

const char* tsk_status_name(tsk_status status) {
    switch (status) {
        case TSK_OK:
            return "ok";
        case TSK_ERR_ARGUMENT:
            return "argument";
        case TSK_ERR_IO:
            return "io";
        case TSK_ERR_FORMAT:
            return "format";
        case TSK_ERR_MEMORY:
            return "memory";
        case TSK_ERR_LIMIT:
            return "limit";
        case TSK_ERR_DEVICE:
            return "device";
        case TSK_ERR_CANCELLED:
            return "cancelled";
        case TSK_ERR_INTERNAL:
            return "internal";
    }
    return "unknown";
}

const char* tsk_last_error(void) { return g_message; }

void tsk_clear_error(void) { g_message[0] = '\0'; }

static void set_message(const char* arg, const char* fmt, va_list ap) {
    size_t used = 0;
    if (arg != NULL) {
        int n = snprintf(g_message, sizeof g_message, "%s: ", arg);
        used = n > 0 ? (size_t)n : 0;
        if (used >= sizeof g_message) used = sizeof g_message - 1;
    }
    vsnprintf(g_message + used, sizeof g_message - used, fmt, ap);
}

tsk_status tsk_error(tsk_status status, const char* fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    set_message(NULL, fmt, ap);
    va_end(ap);
    return status;
}

tsk_status tsk_error_arg(tsk_status status, const char* arg, const char* fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    set_message(arg, fmt, ap);
    va_end(ap);
    return status;
}
