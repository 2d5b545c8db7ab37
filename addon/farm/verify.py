"""Is a rendered frame complete? A PNG file is taken as a finished frame when it has the
PNG signature, its IHDR chunk gives the expected width and height, every chunk's CRC
matches its bytes and it ends with the IEND chunk: a frame whose write was cut short
(a killed or cancelled render), a frame of another resolution, a damaged file, or
anything that is not a file fails. The pixels themselves are not judged. Plain Python
(standard library only): the farm's job script runs this file on the render nodes as

    python3 verify.py WIDTH HEIGHT FILE...     (exit 0: every file is a finished frame)
"""

import os
import struct
import sys
import zlib

SIGNATURE = b"\x89PNG\r\n\x1a\n"


def check_png(path, width, height):
    """None when `path` is a complete PNG of width x height, else why not (a sentence)."""
    if not os.path.isfile(path):
        return "missing" if not os.path.exists(path) else "not a file"
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(SIGNATURE):
        return "not a PNG file"
    pos, first, size = len(SIGNATURE), True, None
    while pos + 12 <= len(data):  # one step per chunk (a handful), never per pixel
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        end = pos + 12 + length
        if end > len(data):
            return "cut short (a chunk runs past the end of the file)"
        body = data[pos + 8:end - 4]
        if zlib.crc32(kind + body) != struct.unpack(">I", data[end - 4:end])[0]:
            return f"damaged (the CRC of its {kind.decode('latin-1')} chunk does not match)"
        if first:
            if kind != b"IHDR" or length < 8:
                return "no IHDR chunk first"
            size = struct.unpack(">II", body[:8])
            first = False
        if kind == b"IEND":
            if end != len(data):
                return "bytes after its IEND chunk"
            if size != (width, height):
                return f"{size[0]} x {size[1]} pixels, not {width} x {height}"
            return None
        pos = end
    return "cut short (no IEND chunk)"


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip().splitlines()[-1].strip(), file=sys.stderr)
        return 2
    width, height = int(argv[0]), int(argv[1])
    bad = 0
    for path in argv[2:]:
        why = check_png(path, width, height)
        if why:
            print(f"verify: {path}: {why}", file=sys.stderr)
            bad += 1
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
