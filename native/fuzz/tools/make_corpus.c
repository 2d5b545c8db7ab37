/* Writes the seed corpus of the fuzz targets into native/fuzz/corpus/<target>/ (run from the
 * repository root after a release build):
 *   cc -O1 -Inative/include -Inative/tests native/fuzz/tools/make_corpus.c \
 *      build/release/libtussock.a $(pkg-config --libs opencv4 libopenni2) -losdCPU \
 *      -lstdc++ -lm -o /tmp/make_corpus && /tmp/make_corpus
 * Small valid depth images (PNG16, EXR), a two-frame .oni recording, small pictures, bake
 * caches (a frame file and a .pc2 made by the library's writers, prefixed by the byte that
 * picks fuzz_bake's mode, and seeds for its structured modes), and
 * byte strings for the definition targets: all 0x0a reads as "every field at its default"
 * (see fuzz.h), a few others as single edge values. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "oni_writer.h"
#include "tussock/bake.h"
#include "tussock/capture.h"

static void put(const char* dir, const char* name, const void* data, size_t n) {
    char path[512];
    mkdir("native/fuzz/corpus", 0755);
    snprintf(path, sizeof path, "native/fuzz/corpus/%s", dir);
    mkdir(path, 0755);
    snprintf(path, sizeof path, "native/fuzz/corpus/%s/%s", dir, name);
    FILE* f = fopen(path, "wb");
    if (!f || fwrite(data, 1, n, f) != n) {
        perror(path);
        exit(1);
    }
    fclose(f);
}

static void copy_file(const char* from, const char* dir, const char* name, unsigned char prefix,
                      int use_prefix) {
    FILE* f = fopen(from, "rb");
    if (!f) {
        perror(from);
        exit(1);
    }
    unsigned char* buf = malloc(1 << 20);
    size_t n = 0;
    if (use_prefix) buf[n++] = prefix;
    n += fread(buf + n, 1, (1 << 20) - n, f);
    fclose(f);
    put(dir, name, buf, n);
    free(buf);
}

/* a blade-like depth image: a few slanted strips at 0.5 m on no data */
static void blades(float* d, int w, int h) {
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int u = (x + y / 4) % 12;
            d[y * w + x] = (u < 3 && y > h / 6) ? 0.5f + 0.001f * y : 0.0f;
        }
}

int main(void) {
    enum { W = 48, H = 40 };
    float d[W * H];
    blades(d, W, H);
    if (tsk_depth_write_png16("/tmp/tsk_corpus.png", d, W, H) != TSK_OK ||
        tsk_depth_write_exr("/tmp/tsk_corpus.exr", d, W, H) != TSK_OK) {
        fprintf(stderr, "%s\n", tsk_last_error());
        return 1;
    }
    copy_file("/tmp/tsk_corpus.png", "depth_files", "blades48x40.png", 0, 0);
    copy_file("/tmp/tsk_corpus.exr", "depth_files", "blades48x40.exr", 0, 0);
    copy_file("samples/blades/depth_0001.png", "depth_files", "sample_0001.png", 0, 0);
    copy_file("samples/blades/cluster.exr", "depth_files", "sample_cluster.exr", 0, 0);
    /* pictures: the same files as pictures (prefix byte 0 = load a file) */
    copy_file("/tmp/tsk_corpus.png", "picture", "file_png16", 0, 1);
    copy_file("/tmp/tsk_corpus.exr", "picture", "file_exr", 0, 1);
    {
        unsigned char b[2048];
        for (size_t i = 0; i < sizeof b; ++i) b[i] = (unsigned char)(i * 37 + 11);
        b[0] = 1; /* synthetic picture */
        put("picture", "synthetic", b, sizeof b);
    }
    /* .oni: two frames */
    {
        oni_writer ow;
        uint16_t mm[W * H];
        if (oniw_open(&ow, "/tmp/tsk_corpus.oni", W, H, 1.0, 0.8) != 0) return 1;
        for (int f = 0; f < 2; ++f) {
            for (int i = 0; i < W * H; ++i) mm[i] = (uint16_t)(d[i] * 1000.0f + f);
            if (oniw_frame(&ow, mm) != 0) return 1;
        }
        if (oniw_close(&ow) != 0) return 1;
        copy_file("/tmp/tsk_corpus.oni", "oni", "two_frames.oni", 0, 0);
    }
    /* definition targets */
    /* bake caches: a 5-point frame file (mode 0), a 3-frame .pc2 (mode 1), and byte
       strings for the structured modes 2 (frames), 4 (.pc2 header) and 5 (write) */
    {
        float pts[3][15];
        const char* paths[3] = {"/tmp/tsk_corpus_1.tskf", "/tmp/tsk_corpus_2.tskf",
                                "/tmp/tsk_corpus_3.tskf"};
        for (int f = 0; f < 3; ++f) {
            for (int i = 0; i < 15; ++i) pts[f][i] = 0.01f * (float)(i + 7 * f);
            if (tsk_bake_write_frame(paths[f], f + 1, pts[f], 5) != TSK_OK) return 1;
        }
        if (tsk_bake_assemble_pc2("/tmp/tsk_corpus.pc2", paths, 3, 1.0f, 1.0f) != TSK_OK) {
            fprintf(stderr, "%s\n", tsk_last_error());
            return 1;
        }
        copy_file(paths[0], "bake", "frame", 0, 1);
        copy_file("/tmp/tsk_corpus.pc2", "bake", "pc2", 1, 1);
        unsigned char b[1024];
        const unsigned char modes[3] = {2, 4, 5};
        const char* names[3] = {"frames", "pc2_header", "write"};
        for (int m = 0; m < 3; ++m) {
            memset(b, 0x0a, sizeof b);
            b[0] = modes[m];
            put("bake", names[m], b, sizeof b);
        }
    }
    const char* defs[] = {"capture_def", "meadow", "wind", "tree", "refine", "sim"};
    for (size_t t = 0; t < sizeof defs / sizeof *defs; ++t) {
        unsigned char b[4096];
        memset(b, 0x0a, sizeof b);
        put(defs[t], "defaults", b, sizeof b);
        for (int k = 0; k < 4; ++k) {
            char name[32];
            for (size_t i = 0; i < sizeof b; ++i)
                b[i] = (i % (7 + k) == 0) ? (unsigned char)k : 0x0a;
            snprintf(name, sizeof name, "edges%d", k);
            put(defs[t], name, b, 512 + 512 * k);
        }
    }
    puts("corpus written");
    return 0;
}
