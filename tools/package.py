#!/usr/bin/python3
"""Makes the installable zips from addon/ (with the built _tussock.abi3.so):
  dist/tussock-VERSION-legacy.zip     a tussock/ folder, for Blender 3.4-4.1 (Install Add-on)
  dist/tussock-VERSION-extension.zip  files at the root with blender_manifest.toml, for 4.2+
blender_manifest.toml is written from manifest.toml, the single source of metadata.

usage: package.py REPO DIST [ADDON_DIR] [--platform linux_x64]
  ADDON_DIR: an add-on folder laid out by build.sh for a Blender in a Debian root, whose
  sources are links into addon/ (default REPO/addon).
  --platform P: write only dist/tussock-VERSION-P.zip, the self-contained extension for one
  platform (the portable build's folder, with its libraries in lib/; docs/platforms.md)."""

import os
import sys
import tomllib
import zipfile

EXCLUDE_DIRS = {"__pycache__"}
EXCLUDE_EXT = {".pyc", ".blend1"}


def toml_value(value):
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def blender_manifest(meta):
    """The 4.2+ extension manifest: the keys Blender reads, taken from manifest.toml."""
    keys = ["schema_version", "id", "version", "name", "tagline", "maintainer", "type"]
    lines = [f"{k} = {toml_value(meta[k])}" for k in keys]
    lines.append(f'blender_version_min = {toml_value(meta["extension_blender_version_min"])}')
    for k in ("tags", "license", "platforms"):
        if k in meta:
            lines.append(f"{k} = {toml_value(meta[k])}")
    lines.append("")
    lines.append("[permissions]")
    for k, reason in meta.get("permissions", {}).items():
        lines.append(f"{k} = {toml_value(reason)}")
    return "\n".join(lines) + "\n"


def addon_files(addon_dir):
    for root, dirs, files in os.walk(addon_dir, followlinks=True):
        dirs[:] = sorted(d for d in dirs if d not in EXCLUDE_DIRS)
        for name in sorted(files):
            if os.path.splitext(name)[1] in EXCLUDE_EXT:
                continue
            path = os.path.join(root, name)
            yield path, os.path.relpath(path, addon_dir)


def write_zip(path, entries):
    tmp = path + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for arcname, src, data in entries:
            info = zipfile.ZipInfo(arcname, date_time=(2020, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            # programs keep their execute bit for unzip tools that honour it
            # (Blender's installer does not; addon/native.py restores it)
            mode = 0o755 if src is not None and os.access(src, os.X_OK) else 0o644
            info.external_attr = mode << 16
            if src is not None:
                with open(src, "rb") as f:
                    data = f.read()
            z.writestr(info, data)
    os.replace(tmp, path)


def extension_entries(files, meta):
    """The entries of a 4.2+ extension zip: the add-on's files at the root and the manifest."""
    return ([(rel, src, None) for src, rel in files]
            + [("blender_manifest.toml", None, blender_manifest(meta).encode())])


# Blender's platform names (blender_manifest.toml) for the zips' suffixes
PLATFORMS = {"linux_x64": "linux-x64", "windows_x64": "windows-x64"}


def main(repo, dist, addon_dir=None, platform=None):
    with open(os.path.join(repo, "manifest.toml"), "rb") as f:
        meta = tomllib.load(f)
    addon_dir = addon_dir or os.path.join(repo, "addon")
    built = ("_tussock.abi3.so", "tussock_oni_reader")
    if platform == "windows_x64":
        built = ("_tussock.pyd",)
    for name in built:
        if not os.path.isfile(os.path.join(addon_dir, name)):
            sys.exit(f"package.py: {addon_dir}/{name} is missing; run ./build.sh build")
    os.makedirs(dist, exist_ok=True)
    files = list(addon_files(addon_dir))
    base = f'{meta["id"]}-{meta["version"]}'
    if platform is not None:
        if platform not in PLATFORMS:
            sys.exit(f"package.py: unknown platform {platform!r}: {', '.join(PLATFORMS)}")
        path = os.path.join(dist, f"{base}-{platform}.zip")
        write_zip(path, extension_entries(files, dict(meta, platforms=[PLATFORMS[platform]])))
        print(path)
        return
    legacy = os.path.join(dist, base + "-legacy.zip")
    write_zip(legacy, [(f'{meta["id"]}/{rel}', src, None) for src, rel in files])
    ext = os.path.join(dist, base + "-extension.zip")
    write_zip(ext, extension_entries(files, meta))
    print(legacy)
    print(ext)


if __name__ == "__main__":
    args = sys.argv[1:]
    plat = None
    if "--platform" in args:
        i = args.index("--platform")
        plat = args[i + 1] if i + 1 < len(args) else sys.exit("package.py: --platform needs a name")
        del args[i:i + 2]
    main(*args[:3], platform=plat)
