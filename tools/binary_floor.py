"""Checks that the binaries of an extension zip (or its unpacked folder) load on a base system:
ELF and PE readers in plain Python, no binutils (issue 41).

An ELF binary (Linux x86-64) may need only the base libraries that manylinux_2_28 allows, or
a library shipped in the zip that its RPATH/RUNPATH ($ORIGIN...) leads the loader to, and no
symbol version above the floor (GLIBC_2.28, GLIBCXX_3.4.25, CXXABI_1.3.11, GCC_8.0). A PE
binary (Windows x64) may import only DLLs shipped in the zip, python3.dll and DLLs Windows
itself ships. Binaries are found by their magic bytes, not their names.

    python3 tools/binary_floor.py PATH [--glibc 2.28] [--glibcxx 3.4.25] [--cxxabi 1.3.11]
                                       [--gcc 8.0]

PATH is a zip, a folder or one binary. One line per binary (what it needs, its highest
versions), one per violation, then 'N passed, N failed' (binaries); exit status 1 on any
violation. From Python: check(path, **floors) -> [(binary, problem)], elf_info(path or
bytes), pe_imports(path or bytes), pe_info(path or bytes). Standard library only, Python 3.9+
(it also runs in the Debian 11 root)."""

import argparse
import dataclasses
import os
import posixpath
import re
import stat
import struct
import sys
import zipfile

# What the loader finds on any Linux system manylinux_2_28 covers: glibc's libraries and
# libgcc_s. Everything else (libstdc++ included) must be shipped in the zip or linked in.
ELF_BASE_LIBS = frozenset((
    "libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1", "libgcc_s.so.1",
    "ld-linux-x86-64.so.2",
))
# The highest version of each family a binary may need: the libraries of manylinux_2_28
# (glibc 2.28, GCC 8's libstdc++ and libgcc_s).
DEFAULT_FLOORS = {"glibc": "2.28", "glibcxx": "3.4.25", "cxxabi": "1.3.11", "gcc": "8.0"}
FAMILIES = (("GLIBC_", "glibc"), ("GLIBCXX_", "glibcxx"), ("CXXABI_", "cxxabi"), ("GCC_", "gcc"))
# Unnumbered versions GCC 8's x86-64 libstdc++ already defines (auditwheel's policies list
# them from manylinux_2_24 on). Any other unnumbered one (GLIBC_PRIVATE, GLIBC_ABI_DT_RELR
# of glibc 2.36, ...) is a violation.
NAMED_VERSIONS_OK = frozenset(("CXXABI_TM_1", "CXXABI_FLOAT128"))

# DLLs a PE binary may import without shipping them: python3.dll (the stable ABI's, which
# Blender ships; a python3X.dll would tie the module to one Python) and DLLs that Windows
# itself installs. The C runtime is the Universal CRT (ucrtbase.dll and its api-ms-win-crt-*
# forwarders, part of Windows 10 and later) or the old msvcrt.dll; VCRUNTIME140.dll and
# MSVCP140.dll are not Windows's and must be shipped.
PE_SYSTEM_DLLS = frozenset(n.lower() for n in (
    "python3.dll", "KERNEL32.dll", "USER32.dll", "ADVAPI32.dll", "WS2_32.dll", "msvcrt.dll",
    "ucrtbase.dll", "SHELL32.dll", "ole32.dll", "OLEAUT32.dll", "bcrypt.dll", "GDI32.dll",
    "COMDLG32.dll", "WINMM.dll", "SHLWAPI.dll", "CRYPT32.dll", "IPHLPAPI.DLL", "SETUPAPI.dll",
    "CFGMGR32.dll", "dbghelp.dll", "psapi.dll",
))
PE_SYSTEM_PREFIXES = ("api-ms-win-crt-", "api-ms-win-core-")  # Windows's API-set forwarders

ELF_MACHINE_X86_64 = 62
PE_MACHINE_AMD64 = 0x8664
ELF_MACHINES = {3: "i386", 20: "ppc", 21: "ppc64", 22: "s390", 40: "arm", 62: "x86-64",
                183: "aarch64", 243: "riscv"}
ELF_TYPES = {0: "NONE", 1: "REL", 2: "EXEC", 3: "DYN", 4: "CORE"}
PE_MACHINES = {0x14C: "i386", 0x1C4: "arm", 0x8664: "x64", 0xAA64: "arm64"}

PT_LOAD, PT_DYNAMIC, PT_INTERP = 1, 2, 3
SHT_NOBITS, SHT_DYNAMIC = 8, 6
DT_NULL, DT_NEEDED, DT_STRTAB, DT_STRSZ, DT_SONAME, DT_RPATH, DT_RUNPATH = 0, 1, 5, 10, 14, 15, 29
DT_VERNEED, DT_VERNEEDNUM = 0x6FFFFFFE, 0x6FFFFFFF


class FormatError(ValueError):
    """The bytes are not a readable ELF64 little-endian or PE32+ binary: a wrong kind of
    file, or one cut short or corrupt."""


@dataclasses.dataclass
class ElfInfo:
    machine: int
    type: int
    needed: list  # DT_NEEDED names, in order
    soname: object = None  # str or None, as are rpath and runpath
    rpath: object = None
    runpath: object = None
    interp: object = None  # PT_INTERP, the program loader of an executable
    version_needs: dict = dataclasses.field(default_factory=dict)  # file -> [version names]

    @property
    def machine_name(self):
        return ELF_MACHINES.get(self.machine, f"machine {self.machine}")


@dataclasses.dataclass
class PeInfo:
    machine: int
    imports: list  # DLL names of the import directory, in order
    delay_imports: list  # DLL names of the delay-load import directory

    @property
    def machine_name(self):
        return PE_MACHINES.get(self.machine, f"machine {self.machine:#x}")


def _bytes(src):
    if isinstance(src, (bytes, bytearray)):
        return src
    if isinstance(src, memoryview):
        return src.tobytes()
    with open(src, "rb") as f:
        return f.read()


def _unpack(fmt, data, off, what):
    size = struct.calcsize(fmt)
    if off < 0 or off + size > len(data):
        raise FormatError(f"cut short: {what} at offset {off:#x} ({size} bytes) runs past the "
                          f"end of the file ({len(data)} bytes)")
    return struct.unpack_from(fmt, data, off)


def _cstr(data, off, what, end=None):
    end = len(data) if end is None else min(end, len(data))
    if off < 0 or off >= end:
        raise FormatError(f"{what}: offset {off:#x} is outside the file or its string table")
    stop = data.find(b"\0", off, end)
    if stop < 0:
        raise FormatError(f"{what}: the string at {off:#x} has no terminating NUL")
    return data[off:stop].decode("utf-8", "backslashreplace")


# ---------------------------------------------------------------------------------------- ELF

def elf_info(src):
    """ElfInfo of an ELF64 little-endian file (a path or its bytes): the dynamic section's
    NEEDED, SONAME, RPATH and RUNPATH and the version needs (DT_VERNEED), read the way the
    loader does, through the program headers (the section headers only when there are
    none). FormatError for anything else or a file cut short."""
    data = _bytes(src)
    if data[:4] != b"\x7fELF":
        raise FormatError("not an ELF file (no \\x7fELF magic)")
    if len(data) < 16:
        raise FormatError("cut short: the ELF identification is incomplete")
    if data[4] != 2:
        raise FormatError(f"not ELF64: EI_CLASS is {data[4]} (1 = 32-bit)")
    if data[5] != 1:
        raise FormatError(f"not little-endian: EI_DATA is {data[5]} (2 = big-endian)")
    (e_type, e_machine, _, _, e_phoff, e_shoff, _, _, e_phentsize, e_phnum, e_shentsize,
     e_shnum, _) = _unpack("<HHIQQQIHHHHHH", data, 16, "the ELF header")
    segments, dynamic, interp = [], None, None  # segments: (address, file offset, size)
    if e_phnum:
        if e_phentsize < 56:
            raise FormatError(f"program header entries of {e_phentsize} bytes (56 expected)")
        for i in range(e_phnum):
            p_type, _, p_offset, p_vaddr, _, p_filesz, _, _ = _unpack(
                "<IIQQQQQQ", data, e_phoff + i * e_phentsize, f"program header {i}")
            if p_type == PT_LOAD:
                segments.append((p_vaddr, p_offset, p_filesz))
            elif p_type == PT_DYNAMIC:
                dynamic = (p_offset, p_filesz)
            elif p_type == PT_INTERP:
                interp = _cstr(data, p_offset, "PT_INTERP", p_offset + p_filesz)
    elif e_shnum:  # no program headers (an object file): the sections say where things are
        if e_shentsize < 64:
            raise FormatError(f"section header entries of {e_shentsize} bytes (64 expected)")
        for i in range(e_shnum):
            _, sh_type, _, sh_addr, sh_offset, sh_size, _, _, _, _ = _unpack(
                "<IIQQQQIIQQ", data, e_shoff + i * e_shentsize, f"section header {i}")
            if sh_addr and sh_type != SHT_NOBITS:
                segments.append((sh_addr, sh_offset, sh_size))
            if sh_type == SHT_DYNAMIC:
                dynamic = (sh_offset, sh_size)
    info = ElfInfo(machine=e_machine, type=e_type, needed=[], interp=interp)
    if dynamic is None:
        return info  # a static binary needs nothing

    def offset_of(addr, what):
        for vaddr, off, size in segments:
            if vaddr <= addr < vaddr + size:
                return addr - vaddr + off
        raise FormatError(f"{what}: address {addr:#x} is in no segment of the file")

    entries = []  # (tag, value) up to DT_NULL
    off, size = dynamic
    for i in range(size // 16):
        tag, val = _unpack("<qQ", data, off + 16 * i, f"dynamic entry {i}")
        if tag == DT_NULL:
            break
        entries.append((tag, val))
    tags = dict(entries)  # the last of a repeated tag; only DT_NEEDED repeats
    if DT_STRTAB not in tags:
        if any(t in tags for t in (DT_NEEDED, DT_SONAME, DT_RPATH, DT_RUNPATH, DT_VERNEED)):
            raise FormatError("the dynamic section names libraries but has no DT_STRTAB")
        return info
    strtab = offset_of(tags[DT_STRTAB], "DT_STRTAB")
    strend = strtab + tags[DT_STRSZ] if DT_STRSZ in tags else len(data)

    def string(index, what):
        return _cstr(data, strtab + index, what, strend)

    for tag, val in entries:
        if tag == DT_NEEDED:
            info.needed.append(string(val, "DT_NEEDED"))
        elif tag == DT_SONAME:
            info.soname = string(val, "DT_SONAME")
        elif tag == DT_RPATH:
            info.rpath = string(val, "DT_RPATH")
        elif tag == DT_RUNPATH:
            info.runpath = string(val, "DT_RUNPATH")
    if DT_VERNEED in tags:
        info.version_needs = _verneed(data, offset_of(tags[DT_VERNEED], "DT_VERNEED"),
                                      tags.get(DT_VERNEEDNUM, 0), string)
    return info


def _verneed(data, off, count, string):
    """{file: [version names]} of the Elf64_Verneed chain at off (count entries)."""
    needs = {}
    budget = len(data) // 16 + 1  # no file holds more 16-byte records than that
    for i in range(count):
        vn_version, vn_cnt, vn_file, vn_aux, vn_next = _unpack(
            "<HHIII", data, off, f"version need {i}")
        if vn_version != 1:
            raise FormatError(f"version need {i}: revision {vn_version} (1 expected)")
        names = needs.setdefault(string(vn_file, "version need file"), [])
        aux = off + vn_aux
        for j in range(vn_cnt):
            budget -= 1
            if budget < 0:
                raise FormatError("the version needs run on past the size of the file")
            _, _, _, vna_name, vna_next = _unpack("<IHHII", data, aux, f"version need {i}.{j}")
            names.append(string(vna_name, "version name"))
            if vna_next == 0:
                break
            aux += vna_next
        budget -= 1
        if vn_next == 0 or budget < 0:
            break
        off += vn_next
    return needs


# ----------------------------------------------------------------------------------------- PE

def pe_info(src):
    """PeInfo of a PE32+ image (a Windows x64 DLL, .pyd or .exe; a path or its bytes): the
    DLL names of its import and delay-load import directories. FormatError for anything
    else (a 32-bit PE32 image included) or a file cut short."""
    data = _bytes(src)
    if data[:2] != b"MZ":
        raise FormatError("not a PE file (no MZ magic)")
    (e_lfanew,) = _unpack("<I", data, 0x3C, "the DOS header's e_lfanew")
    if data[e_lfanew:e_lfanew + 4] != b"PE\0\0":
        raise FormatError(f"no PE signature at {e_lfanew:#x} (a DOS program, or cut short)")
    coff = e_lfanew + 4
    machine, nsections, _, _, _, opt_size, _ = _unpack("<HHIIIHH", data, coff, "the COFF header")
    opt = coff + 20
    (magic,) = _unpack("<H", data, opt, "the optional header")
    if magic == 0x10B:
        raise FormatError("a PE32 (32-bit) image, not PE32+")
    if magic != 0x20B:
        raise FormatError(f"optional header magic {magic:#x} (0x20b, PE32+, expected)")
    if opt_size < 112:
        raise FormatError(f"an optional header of {opt_size} bytes is too small for PE32+")
    (image_base,) = _unpack("<Q", data, opt + 24, "ImageBase")
    (ndirs,) = _unpack("<I", data, opt + 108, "NumberOfRvaAndSizes")
    ndirs = min(ndirs, (opt_size - 112) // 8)
    sections = []
    for i in range(nsections):
        _, vsize, vaddr, raw_size, raw_ptr = _unpack(
            "<8sIIII", data, opt + opt_size + 40 * i, f"section header {i}")
        sections.append((vaddr, max(vsize, raw_size), raw_ptr, raw_size))
    first = min((s[0] for s in sections), default=len(data))

    def offset_of(rva, what):
        for vaddr, vsize, raw_ptr, raw_size in sections:
            if vaddr <= rva < vaddr + vsize:
                if rva - vaddr >= raw_size:
                    raise FormatError(f"{what}: RVA {rva:#x} is in a section's zero fill")
                return rva - vaddr + raw_ptr
        if rva < first:  # the headers map to themselves
            return rva
        raise FormatError(f"{what}: RVA {rva:#x} is in no section")

    def directory(index):
        if index >= ndirs:
            return 0, 0
        return _unpack("<II", data, opt + 112 + 8 * index, f"data directory {index}")

    info = PeInfo(machine=machine, imports=[], delay_imports=[])
    rva, size = directory(1)  # IMAGE_DIRECTORY_ENTRY_IMPORT
    if rva:
        off = offset_of(rva, "the import directory")
        for i in range(len(data) // 20 + 1):
            desc = _unpack("<IIIII", data, off + 20 * i, f"import descriptor {i}")
            if not any(desc):
                break
            name = desc[3]
            info.imports.append(_cstr(data, offset_of(name, "an import's DLL name"),
                                      "an import's DLL name"))
        else:
            raise FormatError("the import directory has no terminating empty descriptor")
    rva, size = directory(13)  # IMAGE_DIRECTORY_ENTRY_DELAY_IMPORT
    if rva:
        off = offset_of(rva, "the delay-load import directory")
        for i in range(len(data) // 32 + 1):
            desc = _unpack("<8I", data, off + 32 * i, f"delay-load descriptor {i}")
            if not any(desc) or desc[1] == 0:
                break
            attributes, name = desc[0], desc[1]
            if not attributes & 1:  # an old (Visual C++ 6) descriptor holds addresses
                name = (name - image_base) & 0xFFFFFFFF
            info.delay_imports.append(_cstr(data, offset_of(name, "a delay-load DLL name"),
                                            "a delay-load DLL name"))
        else:
            raise FormatError("the delay-load directory has no terminating empty descriptor")
    return info


def pe_imports(src):
    """The DLL names a PE32+ image imports, the delay-loaded ones after the others."""
    info = pe_info(src)
    return info.imports + info.delay_imports


# ------------------------------------------------------------------------------------ checker

def _version_key(text):
    """(2, 28) of '2.28'; None when not all parts are numbers."""
    parts = text.split(".")
    if not all(p.isdigit() for p in parts):
        return None
    return tuple(int(p) for p in parts)


def version_above(version, floor):
    """Whether dotted version '2.29' is above floor '2.28' (numerically: 2.3.4 < 2.28,
    8.0.0 == 8.0)."""
    a, b = _version_key(version), _version_key(floor)
    if a is None or b is None:
        raise ValueError(f"not a dotted version: {version!r} or {floor!r}")
    n = max(len(a), len(b))
    return a + (0,) * (n - len(a)) > b + (0,) * (n - len(b))


def version_problem(name, floors=None):
    """Why version name (GLIBC_2.29, GLIBCXX_3.4.21, ...) is not allowed under floors, or
    None. Names of other families (a shipped library's own) are not judged."""
    floors = dict(DEFAULT_FLOORS, **(floors or {}))
    for prefix, key in FAMILIES:
        if not name.startswith(prefix):
            continue
        if name in NAMED_VERSIONS_OK:
            return None
        if _version_key(name[len(prefix):]) is None:
            return f"not a numbered version, so not one up to {prefix}{floors[key]}"
        if version_above(name[len(prefix):], floors[key]):
            return f"above the floor {prefix}{floors[key]}"
        return None
    return None


def max_versions(info):
    """{'GLIBC': '2.35', ...}: the highest numbered version of each family an ELF needs."""
    best = {}
    for names in info.version_needs.values():
        for name in names:
            for prefix, _ in FAMILIES:
                key = _version_key(name[len(prefix):]) if name.startswith(prefix) else None
                if key is not None and (prefix not in best or key > best[prefix][0]):
                    best[prefix] = (key, name[len(prefix):])
    return {p[:-1]: v for p, (_, v) in best.items()}


@dataclasses.dataclass
class Report:
    name: str  # the binary's path inside the zip or folder
    kind: str  # "ELF", "PE" or "?" (unreadable)
    info: object  # ElfInfo, PeInfo or None
    problems: list


def _search_dirs(rel, info):
    """The zip folders the loader searches for rel's NEEDED libraries (its RUNPATH, else its
    RPATH, $ORIGIN resolved inside the zip), and the problems of its RPATH/RUNPATH."""
    dirs, problems = [], []
    origin = posixpath.dirname(rel)
    use = "RUNPATH" if info.runpath is not None else "RPATH"
    for kind, value in (("RPATH", info.rpath), ("RUNPATH", info.runpath)):
        if value is None:
            continue
        for entry in value.split(":"):
            m = re.match(r"(\$ORIGIN|\$\{ORIGIN\})(/.*)?$", entry)
            if m:
                path = posixpath.normpath(posixpath.join(origin, (m.group(2) or "").lstrip("/")))
                path = "" if path == "." else path
                if path == ".." or path.startswith("../"):
                    problems.append(f"{kind} entry {entry!r} leads out of the extension's folder")
                elif "$" in path:
                    problems.append(f"{kind} entry {entry!r}: only $ORIGIN is allowed")
                elif kind == use:
                    dirs.append(path)
            elif entry.startswith("/"):
                problems.append(f"{kind} entry {entry!r} is absolute (a path of the build "
                                f"machine); use $ORIGIN")
            elif "$" in entry:
                problems.append(f"{kind} entry {entry!r}: only $ORIGIN is allowed")
            else:
                problems.append(f"{kind} entry {entry!r} is relative to the working directory; "
                                f"use $ORIGIN")
    return dirs, problems


def _elf_problems(rel, info, present, floors):
    problems = []
    if info.machine != ELF_MACHINE_X86_64:
        problems.append(f"is {info.machine_name}, not x86-64")
    dirs, path_problems = _search_dirs(rel, info)
    problems += path_problems
    use = "RUNPATH" if info.runpath is not None else "RPATH"
    value = info.runpath if info.runpath is not None else info.rpath
    for lib in info.needed:
        if "/" in lib:
            problems.append(f"needs {lib}: a path, not a library name")
            continue
        if lib in ELF_BASE_LIBS or any(posixpath.join(d, lib) in present for d in dirs):
            continue
        shipped = sorted(p for p in present if posixpath.basename(p) == lib)
        if shipped:
            where = f"{use} {value!r}" if value is not None else "no RPATH or RUNPATH"
            problems.append(f"needs {lib}: shipped as {shipped[0]}, but the loader does not "
                            f"look there ({where})")
        else:
            problems.append(f"needs {lib}: neither a base system library nor shipped")
    for lib, names in info.version_needs.items():
        for name in names:
            why = version_problem(name, floors)
            if why:
                problems.append(f"needs {name} of {lib}: {why}")
    return problems


def _pe_problems(info, present):
    problems = []
    if info.machine != PE_MACHINE_AMD64:
        problems.append(f"is {info.machine_name}, not x64")
    shipped = {posixpath.basename(p).lower() for p in present}
    for how, names in (("imports", info.imports), ("delay-loads", info.delay_imports)):
        for dll in names:
            low = dll.lower()
            if low in shipped or low in PE_SYSTEM_DLLS or low.startswith(PE_SYSTEM_PREFIXES):
                continue
            problems.append(f"{how} {dll}: neither a Windows system DLL nor shipped")
    return problems


def _tree(path):
    """(present, binaries, notes): the file paths of a zip, folder or single file (posix,
    relative); [(path, loader of its bytes)] of those starting with an ELF or MZ magic; and
    [(path, problem)] of entries that will not unpack as files."""
    present, binaries, notes = set(), [], []
    if os.path.isfile(path) and zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as z:
            for item in z.infolist():
                if item.is_dir():
                    continue
                name = posixpath.normpath(item.filename.replace("\\", "/")).lstrip("/")
                if stat.S_ISLNK(item.external_attr >> 16):
                    notes.append((name, "is a symbolic link; Blender unpacks it as a small "
                                        "text file, not as a link"))
                    continue
                present.add(name)
                with z.open(item) as f:
                    head = f.read(4)
                if head[:4] == b"\x7fELF" or head[:2] == b"MZ":
                    binaries.append((name, lambda item=item: z.read(item)))
            return present, sorted((n, load()) for n, load in binaries), notes
    if os.path.isfile(path):
        walk = [(os.path.dirname(path) or ".", [], [os.path.basename(path)])]
        root = os.path.dirname(path) or "."
    elif os.path.isdir(path):
        walk, root = os.walk(path), path
    else:
        raise FileNotFoundError(path)
    real_root = os.path.realpath(root)
    for d, _, names in walk:
        for n in names:
            full = os.path.join(d, n)
            rel = os.path.relpath(full, root).replace(os.sep, "/")
            if not os.path.isfile(full):
                notes.append((rel, "is a broken symbolic link or not a regular file"))
                continue
            present.add(rel)
            inside = os.path.realpath(full).startswith(real_root + os.sep)
            if os.path.islink(full) and inside and os.path.isdir(path):
                continue  # the file it points to is checked itself
            with open(full, "rb") as f:
                head = f.read(4)
            if head[:4] == b"\x7fELF" or head[:2] == b"MZ":
                binaries.append((rel, _bytes(full)))
    return present, sorted(binaries), notes


def scan(path, **floors):
    """[Report] for every ELF and PE binary of a zip, folder or single binary, and for
    entries that will not unpack as files."""
    unknown = set(floors) - set(DEFAULT_FLOORS)
    if unknown:
        raise TypeError(f"unknown floors {sorted(unknown)}; known: {sorted(DEFAULT_FLOORS)}")
    for key, value in floors.items():
        if _version_key(str(value)) is None:
            raise ValueError(f"floor {key}={value!r} is not a dotted version")
    floors = dict(DEFAULT_FLOORS, **{k: str(v) for k, v in floors.items()})
    present, binaries, notes = _tree(path)
    reports = [Report(name, "?", None, [problem]) for name, problem in notes]
    for name, data in binaries:
        if data[:4] == b"\x7fELF":
            try:
                info = elf_info(data)
            except FormatError as e:
                reports.append(Report(name, "ELF", None, [f"unreadable ELF: {e}"]))
                continue
            reports.append(Report(name, "ELF", info, _elf_problems(name, info, present, floors)))
        else:
            e_lfanew = struct.unpack_from("<I", data, 0x3C)[0] if len(data) >= 0x40 else None
            if e_lfanew is None or data[e_lfanew:e_lfanew + 4] != b"PE\0\0":
                continue  # MZ by chance (or a DOS program): not a Windows binary
            try:
                info = pe_info(data)
            except FormatError as e:
                reports.append(Report(name, "PE", None, [f"unreadable PE: {e}"]))
                continue
            reports.append(Report(name, "PE", info, _pe_problems(info, present)))
    return reports


def check(path, **floors):
    """[(binary, problem)] of a zip, folder or single binary; empty when all pass. floors:
    glibc, glibcxx, cxxabi, gcc as dotted versions (DEFAULT_FLOORS otherwise)."""
    return [(r.name, p) for r in scan(path, **floors) for p in r.problems]


def describe(report):
    """The one line of a binary: what it needs and its highest versions."""
    info = report.info
    if info is None:
        return f"{report.name}  {report.kind}  unreadable"
    if isinstance(info, PeInfo):
        line = f"{report.name}  PE {info.machine_name}  imports {' '.join(info.imports) or '-'}"
        if info.delay_imports:
            line += f"  delay-loads {' '.join(info.delay_imports)}"
        return line
    line = (f"{report.name}  ELF {info.machine_name}  needs {' '.join(info.needed) or '-'}")
    if info.runpath is not None:
        line += f"  RUNPATH {info.runpath}"
    if info.rpath is not None:
        line += f"  RPATH {info.rpath}"
    best = max_versions(info)
    line += f"  max GLIBC_{best['GLIBC']}" if "GLIBC" in best else "  no GLIBC versions"
    for family in ("GLIBCXX", "CXXABI", "GCC"):
        if family in best:
            line += f" {family}_{best[family]}"
    return line


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("path", help="an extension zip, its unpacked folder, or one binary")
    for key, value in DEFAULT_FLOORS.items():
        ap.add_argument(f"--{key}", default=value, metavar="X.Y",
                        help=f"highest {key.upper()}_ version allowed (default {value})")
    args = ap.parse_args(argv)
    floors = {k: getattr(args, k) for k in DEFAULT_FLOORS}
    try:
        reports = scan(args.path, **floors)
    except (OSError, ValueError, zipfile.BadZipFile) as e:
        print(f"binary_floor: {args.path}: {e}", file=sys.stderr)
        return 2
    failed = 0
    for r in reports:
        if r.info is not None or r.kind != "?":
            print(describe(r))
        for p in r.problems:
            print(f"  FAIL {r.name}: {p}")
        failed += bool(r.problems)
    if not reports:
        print(f"(no ELF or PE binary in {args.path})")
    print(f"{len(reports) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
