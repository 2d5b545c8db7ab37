"""tools/binary_floor.py: its ELF reader against readelf on this machine's binaries, its PE
reader on a PE image built here byte by byte (and on a MinGW DLL when x86_64-w64-mingw32-gcc
is there), and its checker on small libraries built with cc. Plain python3:
    /usr/bin/python3 tests/test_binary_floor.py [NAME...]"""

import os
import random
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zipfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, os.path.join(ROOT, "tools"))
import binary_floor as bf  # noqa: E402
import harness  # noqa: E402

TOOL = os.path.join(ROOT, "tools", "binary_floor.py")
MODULE = os.path.join(ROOT, "addon", "_tussock.abi3.so")
REAL_ELFS = ["/usr/bin/python3", "/usr/lib/x86_64-linux-gnu/libstdc++.so.6",
             "/usr/lib/x86_64-linux-gnu/libc.so.6", MODULE]
CC = shutil.which("cc")
MINGW = shutil.which("x86_64-w64-mingw32-gcc")


def skip(why):
    print(f"     skipped: {why}")


def readelf(args, path):
    out = subprocess.run(["readelf", *args, path], stdout=subprocess.PIPE, check=True,
                         env=dict(os.environ, LC_ALL="C"), universal_newlines=True).stdout
    return out


def readelf_info(path):
    """(needed, soname, rpath, runpath, {file: [version names]}) as readelf prints them."""
    dyn = readelf(["-d", "--wide"], path)

    def one(kind):
        found = re.findall(rf"\(({kind})\)\s+\S.*?: \[(.*)\]", dyn)
        return found[-1][1] if found else None
    needed = [m for m in re.findall(r"\(NEEDED\)\s+Shared library: \[(.*)\]", dyn)]
    needs, current = {}, None
    text = readelf(["-V", "--wide"], path)
    part = text.split("Version needs section", 1)[1] if "Version needs section" in text else ""
    part = part.split("\nVersion ", 1)[0]  # up to a following version section, if any
    for line in part.splitlines():
        m = re.search(r"File: (\S+)\s+Cnt:", line)
        if m:
            current = needs.setdefault(m.group(1), [])
            continue
        m = re.search(r"Name: (\S+)\s+Flags:", line)
        if m:
            current.append(m.group(1))
    return needed, one("SONAME"), one("RPATH"), one("RUNPATH"), needs


def assert_agrees_with_readelf(path):
    info = bf.elf_info(path)
    needed, soname, rpath, runpath, needs = readelf_info(path)
    assert info.needed == needed, (path, info.needed, needed)
    assert (info.soname, info.rpath, info.runpath) == (soname, rpath, runpath), (
        path, info, soname, rpath, runpath)
    assert info.version_needs == needs, (path, info.version_needs, needs)
    return info, needs


def cc(tmp, out, source, *flags):
    """Builds out (in tmp) from C source with cc; returns its path."""
    src = os.path.join(tmp, os.path.basename(out) + ".c")
    with open(src, "w", encoding="utf-8") as f:
        f.write(source)
    path = os.path.join(tmp, out)
    subprocess.run([CC, "-O1", "-o", path, src, *flags], check=True, cwd=tmp)
    return path


HELLO = '#include <stdio.h>\nvoid hello(void) { puts("hello"); }\n'
CALLER = "void hello(void);\nvoid call(void) { hello(); }\n"


def build_pair(tmp, rpath, *flags):
    """libhello.so (libc only) and libcall.so, which NEEDs libhello.so, with RPATH rpath."""
    hello = cc(tmp, "libhello.so", HELLO, "-shared", "-fPIC", "-Wl,-soname,libhello.so")
    call = cc(tmp, "libcall.so", CALLER, "-shared", "-fPIC", f"-L{tmp}", "-lhello",
              f"-Wl,-rpath,{rpath}", *flags)
    return hello, call


def place(root, files):
    """Copies {relative path: source file} under root; returns root."""
    for rel, src in files.items():
        os.makedirs(os.path.dirname(os.path.join(root, rel)), exist_ok=True)
        shutil.copy(src, os.path.join(root, rel))
    return root


def run_cli(*args):
    return subprocess.run([sys.executable, TOOL, *args], stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, universal_newlines=True)


def build_pe(imports=("foo.dll",), delay=(), magic=0x20B, machine=0x8664):
    """A minimal PE32+ image: headers and one .idata section (RVA 0x1000, file 0x200) holding
    an import descriptor per DLL name of imports, then a delay-load descriptor per name of
    delay (RVA-based), each list ended by an empty descriptor, then the names."""
    rva, raw = 0x1000, 0x200
    names_at = 20 * (len(imports) + 1) + 32 * (len(delay) + 1)
    body, strings, name_rvas = bytearray(), bytearray(), []
    for name in list(imports) + list(delay):
        name_rvas.append(rva + names_at + len(strings))
        strings += name.encode() + b"\0"
    for i in range(len(imports)):
        body += struct.pack("<IIIII", 0, 0, 0, name_rvas[i], 0)
    body += bytes(20)
    delay_at = len(body)
    for i in range(len(delay)):
        body += struct.pack("<8I", 1, name_rvas[len(imports) + i], 0, 0, 0, 0, 0, 0)
    body += bytes(32)
    body += strings
    section = bytes(body).ljust(0x200, b"\0")
    dirs = [(0, 0)] * 16
    dirs[1] = (rva, 20 * (len(imports) + 1))
    if delay:
        dirs[13] = (rva + delay_at, 32 * (len(delay) + 1))
    opt = bytearray(240)
    struct.pack_into("<H", opt, 0, magic)
    struct.pack_into("<Q", opt, 24, 0x180000000)  # ImageBase
    struct.pack_into("<I", opt, 108, 16)  # NumberOfRvaAndSizes
    for i, (r, s) in enumerate(dirs):
        struct.pack_into("<II", opt, 112 + 8 * i, r, s)
    head = bytearray(b"MZ".ljust(0x40, b"\0"))
    struct.pack_into("<I", head, 0x3C, 0x40)
    head += b"PE\0\0" + struct.pack("<HHIIIHH", machine, 1, 0, 0, 0, len(opt), 0x2022) + opt
    head += struct.pack("<8sIIIIIIHHI", b".idata", len(section), rva, len(section), raw,
                        0, 0, 0, 0, 0xC0000040)
    return bytes(head.ljust(raw, b"\0")) + section


def problems_of(path, **floors):
    return [p for _, p in bf.check(path, **floors)]


def test_versions_compare_numerically():
    assert not bf.version_above("2.3.4", "2.28") and bf.version_above("2.29", "2.28")
    assert not bf.version_above("2.28", "2.28") and not bf.version_above("8.0.0", "8.0")
    assert bf.version_above("3.4.26", "3.4.25") and not bf.version_above("3.4.9", "3.4.25")
    assert bf.version_above("1.3.12", "1.3.11") and bf.version_above("12.0.0", "8.0")
    assert bf.version_problem("GLIBC_2.2.5") is None
    assert "above the floor GLIBC_2.28" in bf.version_problem("GLIBC_2.34")
    assert bf.version_problem("GLIBC_2.34", {"glibc": "2.34"}) is None
    assert "GLIBCXX_3.4.25" in bf.version_problem("GLIBCXX_3.4.29")
    assert bf.version_problem("GLIBCXX_3.4.25") is None
    assert bf.version_problem("CXXABI_1.3.11") is None and bf.version_problem("CXXABI_1.3.13")
    assert bf.version_problem("GCC_7.0.0") is None and bf.version_problem("GCC_12.0.0")
    assert bf.version_problem("CXXABI_TM_1") is None
    for bad in ("GLIBC_PRIVATE", "GLIBC_ABI_DT_RELR"):
        assert "not a numbered version" in bf.version_problem(bad), bad
    assert bf.version_problem("OPENSSL_3.0.0") is None  # a shipped library's own versions


def test_elf_info_agrees_with_readelf():
    if not shutil.which("readelf"):
        return skip("no readelf")
    compared = []
    for path in REAL_ELFS:
        if not os.path.exists(path):
            continue
        info, needs = assert_agrees_with_readelf(path)
        assert info.needed and info.machine == bf.ELF_MACHINE_X86_64, (path, info)
        compared.append(os.path.basename(path))
    assert "python3" in compared, compared
    libc = bf.elf_info("/usr/lib/x86_64-linux-gnu/libc.so.6")
    assert libc.soname == "libc.so.6" and "ld-linux-x86-64.so.2" in libc.needed, libc
    libstdcxx = bf.elf_info("/usr/lib/x86_64-linux-gnu/libstdc++.so.6")
    assert "GLIBC_2.2.5" in libstdcxx.version_needs["libc.so.6"], libstdcxx.version_needs
    assert "GCC_3.0" in libstdcxx.version_needs["libgcc_s.so.1"], libstdcxx.version_needs


def test_elf_info_reads_rpath_and_runpath_of_built_libraries():
    if not CC:
        return skip("no cc")
    with tempfile.TemporaryDirectory() as tmp:
        _, call = build_pair(tmp, "$ORIGIN/lib:$ORIGIN")
        info = bf.elf_info(call)
        assert info.needed[0] == "libhello.so" and info.runpath == "$ORIGIN/lib:$ORIGIN", info
        assert info.rpath is None, info
        if shutil.which("readelf"):
            assert_agrees_with_readelf(call)
        _, old = build_pair(tmp, "$ORIGIN", "-Wl,--disable-new-dtags")
        info = bf.elf_info(old)
        assert (info.rpath, info.runpath) == ("$ORIGIN", None), info
        if shutil.which("readelf"):
            assert_agrees_with_readelf(old)


def test_checker_fails_the_built_module():
    if not os.path.exists(MODULE):
        return skip(f"no {MODULE}")
    with tempfile.TemporaryDirectory() as tmp:
        place(tmp, {"_tussock.abi3.so": MODULE})
        found = bf.check(tmp)
        assert found and {b for b, _ in found} == {"_tussock.abi3.so"}, found
        text = "\n".join(p for _, p in found)
        for lib in ("libstdc++.so.6", "libopencv_core.so.406"):
            assert f"needs {lib}: neither a base system library nor shipped" in text, text
        for base in ("libc.so.6:", "libm.so.6:", "libgcc_s.so.1:", "ld-linux-x86-64.so.2:"):
            assert f"needs {base}" not in text, text  # the base set is allowed
        assert re.search(r"needs GLIBC_2\.(29|3\d) of lib[cm]\.so\.6: above the floor "
                         r"GLIBC_2\.28", text), text
        assert re.search(r"needs GLIBCXX_3\.4\.(2[6-9]|3\d) of libstdc\+\+\.so\.6", text), text
        out = run_cli(tmp)
        assert out.returncode == 1, out.stdout
        lines = out.stdout.splitlines()
        assert lines[-1] == "0 passed, 1 failed", lines
        assert lines[0].startswith("_tussock.abi3.so  ELF x86-64  needs "), lines
        assert re.search(r"max GLIBC_2\.\d+", lines[0]), lines
        assert len([x for x in lines if x.startswith("  FAIL ")]) == len(found), lines
        # a higher floor lets the versions through, never the missing libraries
        high = problems_of(tmp, glibc="2.99", glibcxx="3.4.99", cxxabi="1.3.99", gcc="99")
        assert high and all("above the floor" not in p for p in high), high


def test_checker_passes_a_library_that_needs_only_old_glibc():
    if not CC:
        return skip("no cc")
    with tempfile.TemporaryDirectory() as tmp:
        hello = cc(tmp, "libhello.so", HELLO, "-shared", "-fPIC")
        info = bf.elf_info(hello)
        assert info.needed == ["libc.so.6"], info
        assert "GLIBC_2.2.5" in info.version_needs["libc.so.6"], info.version_needs  # puts
        root = place(os.path.join(tmp, "ext"), {"libhello.so": hello})
        assert bf.check(root) == [], bf.check(root)
        out = run_cli(root)
        assert out.returncode == 0 and out.stdout.splitlines()[-1] == "1 passed, 0 failed", out
        assert "max GLIBC_2.2.5" in out.stdout, out.stdout
        # a floor below what it needs fails it: the floor is compared, not just printed
        low = problems_of(root, glibc="2.2")
        assert low == ["needs GLIBC_2.2.5 of libc.so.6: above the floor GLIBC_2.2"], low
        # a program linked against glibc >= 2.34 needs __libc_start_main@GLIBC_2.34
        prog = cc(tmp, "prog", 'int main(void) { return 0; }\n')
        newest = bf.max_versions(bf.elf_info(prog))["GLIBC"]
        above = bf.version_above(newest, "2.28")
        assert bool(problems_of(prog)) == above, (newest, problems_of(prog))


def test_checker_follows_origin():
    if not CC:
        return skip("no cc")
    with tempfile.TemporaryDirectory() as tmp:
        hello, call = build_pair(tmp, "$ORIGIN/lib")
        good = place(os.path.join(tmp, "good"), {"libcall.so": call, "lib/libhello.so": hello})
        assert bf.check(good) == [], bf.check(good)
        elsewhere = place(os.path.join(tmp, "elsewhere"),
                          {"libcall.so": call, "other/libhello.so": hello})
        assert problems_of(elsewhere) == [
            "needs libhello.so: shipped as other/libhello.so, but the loader does not look "
            "there (RUNPATH '$ORIGIN/lib')"], problems_of(elsewhere)
        missing = place(os.path.join(tmp, "missing"), {"libcall.so": call})
        assert problems_of(missing) == [
            "needs libhello.so: neither a base system library nor shipped"]
        # the zip of a folder is judged as the folder
        for folder, ok in ((good, True), (elsewhere, False)):
            z = folder + ".zip"
            with zipfile.ZipFile(z, "w") as out:
                for rel in ("libcall.so", "lib/libhello.so", "other/libhello.so"):
                    if os.path.exists(os.path.join(folder, rel)):
                        out.write(os.path.join(folder, rel), "tussock/" + rel)
            assert (bf.check(z) == []) == ok, bf.check(z)
            assert run_cli(z).returncode == (0 if ok else 1)
        # $ORIGIN/.. from a subfolder, as RPATH (old tags) this time
        _, up = build_pair(tmp, "$ORIGIN/../lib", "-Wl,--disable-new-dtags")
        nested = place(os.path.join(tmp, "nested"), {"bin/libcall.so": up,
                                                     "lib/libhello.so": hello})
        assert bf.check(nested) == [], bf.check(nested)
        no_path = place(os.path.join(tmp, "no_path"), {"bin/libcall.so": up,
                                                       "bin/lib/libhello.so": hello})
        assert "shipped as bin/lib/libhello.so" in problems_of(no_path)[0], problems_of(no_path)
        # $ORIGIN itself, the library shipped as a link to its versioned file (checked once)
        _, flat = build_pair(tmp, "$ORIGIN")
        linked = place(os.path.join(tmp, "linked"), {"libcall.so": flat,
                                                     "libhello.so.1.0": hello})
        os.symlink("libhello.so.1.0", os.path.join(linked, "libhello.so"))
        assert bf.check(linked) == [], bf.check(linked)
        assert run_cli(linked).stdout.splitlines()[-1] == "2 passed, 0 failed"
        # absolute entries, entries out of the folder and relative ones are violations
        for rpath, why in (("/opt/tussock/lib", "absolute"),
                           ("$ORIGIN/../../lib", "leads out of the extension's folder"),
                           ("lib", "relative to the working directory"),
                           ("$ORIGIN/$LIB", "only $ORIGIN is allowed")):
            _, bad = build_pair(tmp, rpath)
            root = place(os.path.join(tmp, "bad"), {"libcall.so": bad, "lib/libhello.so": hello})
            found = problems_of(root)
            assert any(why in p for p in found), (rpath, found)
            shutil.rmtree(root)


def test_a_link_in_a_zip_is_a_violation():
    # Blender unpacks an extension with zipfile, which writes a link as a file of its target
    with tempfile.TemporaryDirectory() as tmp:
        z = os.path.join(tmp, "ext.zip")
        with zipfile.ZipFile(z, "w") as out:
            link = zipfile.ZipInfo("tussock/lib/libhello.so")
            link.external_attr = 0o120777 << 16
            out.writestr(link, "libhello.so.1.0")
            out.writestr("tussock/__init__.py", "")
        assert bf.check(z) == [("tussock/lib/libhello.so", "is a symbolic link; Blender unpacks "
                                "it as a small text file, not as a link")], bf.check(z)


def test_runpath_hides_rpath():
    # the loader ignores DT_RPATH when there is a DT_RUNPATH (ld writes one or the other)
    info = bf.ElfInfo(machine=62, type=3, needed=["libx.so"], rpath="$ORIGIN/a",
                      runpath="$ORIGIN/b")
    assert bf._search_dirs("sub/m.so", info) == (["sub/b"], [])
    found = bf._elf_problems("sub/m.so", info, {"sub/m.so", "sub/a/libx.so"}, bf.DEFAULT_FLOORS)
    assert found == ["needs libx.so: shipped as sub/a/libx.so, but the loader does not look "
                     "there (RUNPATH '$ORIGIN/b')"], found
    assert bf._elf_problems("sub/m.so", info, {"sub/m.so", "sub/b/libx.so"},
                            bf.DEFAULT_FLOORS) == []


def test_readers_raise_format_error_on_bad_files():
    for data in (b"", b"garbage", b"\x7fEL", b"\x7fELF", b"\x7fELF\x02\x01" + bytes(20),
                 b"\x7fELF\x01\x01\x01" + bytes(60), b"\x7fELF\x02\x02\x01" + bytes(60)):
        try:
            bf.elf_info(data)
        except bf.FormatError:
            pass
        else:
            raise AssertionError(data)
    for data in (b"", b"MZ", b"MZ" + bytes(100), build_pe()[:0x100], build_pe(magic=0x10B)):
        try:
            bf.pe_info(data)
        except bf.FormatError:
            pass
        else:
            raise AssertionError(data[:80])
    try:
        bf.pe_info(build_pe(magic=0x10B))
    except bf.FormatError as e:
        assert "PE32 (32-bit)" in str(e), e


def outcome(read, data):
    """read(data), or 'error' for a FormatError; any other exception escapes."""
    try:
        return read(data)
    except bf.FormatError:
        return "error"


def test_cut_and_corrupt_binaries_never_crash_the_readers():
    samples = [(bf.pe_info, build_pe(["KERNEL32.dll", "foo.dll"], ["bar.dll"]))]
    with open("/usr/bin/python3", "rb") as f:
        samples.append((bf.elf_info, f.read()))
    if os.path.exists(MODULE):
        with open(MODULE, "rb") as f:
            samples.append((bf.elf_info, f.read()))
    rng = random.Random(41)
    for read, data in samples:
        whole = read(data)
        # a cut file reads the same or raises FormatError; one cut inside the headers raises
        cuts = sorted(set(list(range(0, 600, 7)) + [rng.randrange(len(data)) for _ in range(60)]))
        for n in cuts:
            got = outcome(read, data[:n])
            assert got in ("error", whole), n
        assert outcome(read, data[:64]) == "error"
        # corrupt bytes in the headers and the tables they point to
        bad = bytearray(data)
        for _ in range(300):
            spots = [rng.randrange(min(len(bad), 0x4000)) for _ in range(rng.randint(1, 6))]
            for i in spots:
                bad[i] = rng.randrange(256)
            outcome(read, bad)
            for i in spots:
                bad[i] = data[i]


def test_cli_reports_an_unreadable_binary_as_a_violation():
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "broken.so"), "wb") as f:
            f.write(b"\x7fELF\x02\x01\x01" + bytes(30))
        with open(os.path.join(tmp, "readme.txt"), "w", encoding="utf-8") as f:
            f.write("MZ is not only a magic\n")  # MZ without a PE header is not a binary
        out = run_cli(tmp)
        assert out.returncode == 1 and "Traceback" not in out.stdout, out.stdout
        assert "  FAIL broken.so: unreadable ELF: cut short" in out.stdout, out.stdout
        assert out.stdout.splitlines()[-1] == "0 passed, 1 failed", out.stdout
        assert run_cli(os.path.join(tmp, "nothing_here")).returncode == 2


def test_pe_reader_and_checker_on_a_built_image():
    image = build_pe(["foo.dll"])
    info = bf.pe_info(image)
    assert (info.machine, info.imports, info.delay_imports) == (0x8664, ["foo.dll"], []), info
    both = build_pe(["KERNEL32.dll", "python3.dll", "api-ms-win-crt-runtime-l1-1-0.dll",
                     "opencv_world4100.dll"], ["Bar.DLL"])
    assert bf.pe_imports(both) == ["KERNEL32.dll", "python3.dll",
                                   "api-ms-win-crt-runtime-l1-1-0.dll", "opencv_world4100.dll",
                                   "Bar.DLL"], bf.pe_imports(both)
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "_tussock.pyd"), "wb") as f:
            f.write(both)
        assert problems_of(tmp) == [
            "imports opencv_world4100.dll: neither a Windows system DLL nor shipped",
            "delay-loads Bar.DLL: neither a Windows system DLL nor shipped"], problems_of(tmp)
        os.makedirs(os.path.join(tmp, "libs"))
        for name in ("libs/OPENCV_WORLD4100.dll", "bar.dll"):  # shipped, any case
            with open(os.path.join(tmp, name), "wb") as f:
                f.write(build_pe(["KERNEL32.dll", "VCRUNTIME140.dll", "python311.dll"]))
        found = bf.check(tmp)
        assert sorted(found) == [
            (b, f"imports {d}: neither a Windows system DLL nor shipped")
            for b in ("bar.dll", "libs/OPENCV_WORLD4100.dll")
            for d in ("VCRUNTIME140.dll", "python311.dll")], found
        out = run_cli(tmp)
        assert out.stdout.splitlines()[-1] == "1 passed, 2 failed", out.stdout
        assert "_tussock.pyd  PE x64  imports KERNEL32.dll" in out.stdout, out.stdout
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "x86.dll"), "wb") as f:
            f.write(build_pe(["KERNEL32.dll"], machine=0x14C))
        assert problems_of(tmp) == ["is i386, not x64"], problems_of(tmp)


def test_pe_reader_on_a_mingw_dll():
    if not MINGW:
        return skip("no x86_64-w64-mingw32-gcc")
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "box.c")
        with open(src, "w", encoding="utf-8") as f:
            f.write("#include <windows.h>\n__declspec(dllexport) int box(void) {\n"
                    '    return MessageBoxA(NULL, "hi", "tussock", MB_OK);\n}\n')
        dll = os.path.join(tmp, "box.dll")
        subprocess.run([MINGW, "-O1", "-shared", "-o", dll, src], check=True)
        names = [n.lower() for n in bf.pe_imports(dll)]
        assert "user32.dll" in names and "kernel32.dll" in names, names
        assert bf.pe_info(dll).machine == bf.PE_MACHINE_AMD64
        found = problems_of(tmp)
        assert not any("USER32" in p.upper() or "KERNEL32" in p.upper() for p in found), found


if __name__ == "__main__":
    sys.exit(harness.run(globals()))
