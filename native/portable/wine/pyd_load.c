/* Loads a Python extension DLL the way Python's importer does (LoadLibraryExW with the DLL's
 * folder searched for its dependencies) and looks up its PyInit_ function, then unloads it:
 * under wine, beside a stand-in python3.dll that exports the stable ABI's names, this shows
 * that Windows's loader resolves every import of the .pyd and that its start-up code runs.
 * It cannot call PyInit_ (there is no Python here).
 *   pyd_load.exe MODULE.pyd INIT_NAME */
#include <stdio.h>
#include <windows.h>

int wmain(int argc, wchar_t** argv) {
    if (argc != 3) {
        fwprintf(stderr, L"usage: pyd_load MODULE.pyd INIT_NAME\n");
        return 2;
    }
    wchar_t path[MAX_PATH]; /* the DLL-folder search wants a full path */
    if (GetFullPathNameW(argv[1], MAX_PATH, path, NULL) == 0) return 1;
    HMODULE m = LoadLibraryExW(path, NULL,
                               LOAD_LIBRARY_SEARCH_DLL_LOAD_DIR | LOAD_LIBRARY_SEARCH_DEFAULT_DIRS);
    if (m == NULL) {
        fwprintf(stderr, L"LoadLibraryExW(%ls) failed: error %lu\n", argv[1], GetLastError());
        return 1;
    }
    char name[256];
    WideCharToMultiByte(CP_UTF8, 0, argv[2], -1, name, sizeof name, NULL, NULL);
    FARPROC init = GetProcAddress(m, name);
    if (init == NULL) {
        fwprintf(stderr, L"%ls exports no %ls\n", argv[1], argv[2]);
        FreeLibrary(m);
        return 1;
    }
    FreeLibrary(m);
    printf("loaded, %s found\n", name);
    return 0;
}
