/* Fuzz target: OpenNI2 recordings, the whole path. The bytes become a .oni file that
 * tsk_depth_open_oni gives to the recording reader process (tussock_oni_reader, which runs
 * OpenNI2's own player); up to three frames are read, the read contract checked, then a
 * seek and another read. A crash of OpenNI2's player must come back as a status: this
 * process must not crash, hang or leak, and no reader process may be left behind (its
 * children are looked up by name: the sanitizers keep a symbolizer process of their own).
 * Slow by nature (a process per input, the player's own thread); fuzz_oni covers the
 * checking of the reader's answers at full speed. Coverage is that of this process only. */
#include "fuzz.h"

#include "tussock/capture.h"

int LLVMFuzzerInitialize(int* argc, char*** argv) {
    (void)argc;
    (void)argv;
    fz_init();
    /* the reader must be there, or every input would only test "reader missing" */
    char self[4096];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 32);
    if (n <= 0) abort();
    self[n] = '\0';
    strcpy(strrchr(self, '/') + 1, "tussock_oni_reader");
    if (getenv("TSK_ONI_READER") == NULL && access(self, X_OK) != 0) {
        fprintf(stderr, "fuzz_oni_file: %s is missing\n", self);
        abort();
    }
    return 0;
}

/* True if a child of this process is a recording reader. Other children are the sanitizers'
 * own (libFuzzer symbolizes new functions with a long-lived llvm-symbolizer process). */
static int reader_left_behind(void) {
    char list[4096] = "";
    FILE* f = fopen("/proc/thread-self/children", "r");
    if (f == NULL) return 0;
    const size_t n = fread(list, 1, sizeof list - 1, f);
    fclose(f);
    list[n] = '\0';
    for (char* tok = strtok(list, " \n"); tok != NULL; tok = strtok(NULL, " \n")) {
        char path[64], comm[32] = "";
        snprintf(path, sizeof path, "/proc/%s/comm", tok);
        FILE* c = fopen(path, "r");
        if (c == NULL) continue;
        if (fgets(comm, sizeof comm, c) == NULL) comm[0] = '\0';
        fclose(c);
        if (strncmp(comm, "tussock_oni_rea", 15) == 0) return 1; /* comm: 15 characters */
    }
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size > (1u << 20)) return 0;
    char path[128];
    if (!fz_write_temp(data, size, "oni", path, sizeof path)) return 0;
    tsk_depth_source* src = NULL;
    if (tsk_depth_open_oni(path, &src) == TSK_OK) {
        tsk_depth_info info;
        if (tsk_depth_get_info(src, &info) != TSK_OK) abort();
        if (info.width <= 0 || info.height <= 0) abort();
        const size_t n = (size_t)info.width * (size_t)info.height;
        float* depth = malloc(n * sizeof *depth);
        tsk_depth_frame fr;
        for (int i = 0; i < 3 && depth != NULL; ++i) {
            if (tsk_depth_read(src, depth, n, &fr) != TSK_OK || !fr.is_new) break;
            for (size_t k = 0; k < n; ++k)
                if (!(depth[k] >= 0.0f) || !isfinite(depth[k])) abort();
        }
        if (tsk_depth_seek(src, 0) == TSK_OK && depth != NULL)
            (void)tsk_depth_read(src, depth, n, &fr);
        (void)tsk_depth_seek(src, -1);
        (void)tsk_depth_seek(src, INT_MAX);
        free(depth);
        tsk_depth_close(src);
    }
    unlink(path);
    if (reader_left_behind()) {
        fprintf(stderr, "tussock fuzz: a recording reader process was left behind\n");
        abort();
    }
    fz_check_leaks("oni_file");
    return 0;
}
