/* A per-process temporary folder for test programs that write files: tmp_path("name") is
 * /tmp/tsk_test_<TSK_TEST_TMP_NAME>_<pid>/name (on Windows in its folder for temporary files).
 * The folder is made on first use and removed at exit with everything in it, read-only folders
 * a test made included. */
#ifndef TSK_TEST_TMP_H
#define TSK_TEST_TMP_H

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "test_os.h"

#ifndef TSK_TEST_TMP_NAME
#error "define TSK_TEST_TMP_NAME (the suite's name, a string) before including test_tmp.h"
#endif

static char g_dir[256];

static void tmp_remove_tree(const char* path) {
    struct stat st;
    if (lstat(path, &st) != 0) return;
    if (!S_ISDIR(st.st_mode)) {
        unlink(path);
        return;
    }
    chmod(path, 0700); /* a read-only folder of a test: its entries can go only then */
    DIR* d = opendir(path);
    if (d != NULL) {
        struct dirent* e;
        char p[1024];
        while ((e = readdir(d)) != NULL) {
            if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
            snprintf(p, sizeof p, "%s/%s", path, e->d_name);
            tmp_remove_tree(p);
        }
        closedir(d);
    }
    rmdir(path);
}

static void tmp_remove_dir(void) {
    if (g_dir[0] != '\0') tmp_remove_tree(g_dir);
}

static const char* tmp_path(const char* name) {
    static char buf[4][512];
    static int k;
    k = (k + 1) % 4;
    if (g_dir[0] == '\0') {
        snprintf(g_dir, sizeof g_dir, "%s/tsk_test_%s_%d", test_tmp_root(), TSK_TEST_TMP_NAME,
                 (int)getpid());
        test_mkdir(g_dir, 0700);
        atexit(tmp_remove_dir);
    }
    snprintf(buf[k], sizeof buf[k], "%s/%s", g_dir, name);
    return buf[k];
}

#endif
