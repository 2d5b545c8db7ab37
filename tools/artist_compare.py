#!/usr/bin/python3
"""Compares two results of tools/artist_check.py: the portable zip on an artist's machine
against the apt build in the same Debian release (build.sh run_artist_checks). Every hash
(captured skeletons from files and from a recording, refined skeletons, the solver's output,
the tree, every baked cache file) and every count must be equal, both runs must have ended
well and rendered their frame, and the scene must not be empty (some blades simulated).
Prints one line per difference and "N passed, N failed" (one check per compared item);
exits 1 on any difference.

An EXR cache whose bytes differ passes when its decoded pixels are equal (another OpenEXR
writes the same pixels in other bytes), and so does its .tski sidecar, which records the
EXR file's size and checksum. With --opencv-differs (the two builds carry different OpenCV
versions, e.g. the zip's Debian 12 OpenCV 4.6 against sid's 4.10) the picture's inpainted
background (cv::inpaint's output: OpenCV 4.10 changed how Telea fills) passes when its
pixels, which artist_check.py keeps beside its JSON, are within BACKGROUND_BOUND of each
other in every channel; the difference is listed as a note.

usage: artist_compare.py [--opencv-differs] PORTABLE.json APT.json"""

import json
import os
import sys

# How far OpenCV 4.6's and 4.10's cv::inpaint may fill the sample picture's background apart
# (colour values 0..1; docs/platforms.md has the measured difference)
BACKGROUND_BOUND = 0.002


def inpainted_background(path):
    """The picture's background, which OpenCV's cv::inpaint fills in (the mattes, layers and
    UV passes come out equal across OpenCV 4.6 and 4.10; the inpainting does not)."""
    parts = path.split("/")
    return len(parts) == 3 and parts[1].endswith("_picture") and parts[2] == "background.exr"


def compare(port, apt, opencv_differs=False, notes=None):
    """The differences between two artist_check results, as a list of lines; `notes` (a
    list) receives what was compared otherwise than byte for byte."""
    notes = [] if notes is None else notes
    bad = []
    for name, d in (("portable", port), ("apt", apt)):
        if not d.get("ok"):
            bad.append(f"the {name} run did not end well: {d.get('error', '?')}")
        if not d.get("render", {}).get("exists"):
            bad.append(f"the {name} run rendered no frame")
        if d.get("counts", {}).get("simulated_blades", 0) <= 0:
            bad.append(f"the {name} run simulated no blade: the collider missed the meadow")
    if port.get("blender") != apt.get("blender"):
        bad.append(f"not the same Blender: {port.get('blender')} and {apt.get('blender')}")
    for group in ("hashes", "caches", "counts"):
        a, b = port.get(group, {}), apt.get(group, {})
        for key in sorted(set(a) | set(b)):
            if key not in a or key not in b:
                bad.append(f"{group}: {key} only in the {'apt' if key in b else 'portable'} run")
            elif a[key] != b[key]:
                why = cache_difference(port, apt, key, opencv_differs) if group == "caches" \
                    else None
                if why is None:
                    bad.append(f"{group}: {key} differs: portable {a[key]} apt {b[key]}")
                else:
                    notes.append(f"{key}: {why}")
    return bad


def cache_difference(port, apt, key, opencv_differs):
    """Why a cache file's differing bytes are acceptable, or None if they are not."""
    exr = key[:-len(".tski")] if key.endswith(".exr.tski") else key
    if not exr.endswith(".exr"):
        return None
    ia, ib = port.get("images", {}).get(exr), apt.get("images", {}).get(exr)
    if ia is None or ib is None:
        return None
    if ia == ib:
        return "other bytes, equal pixels" + (" (sidecar of that EXR)" if key != exr else "")
    if opencv_differs and inpainted_background(exr) and ia["size"] == ib["size"]:
        far = background_difference(port, apt, ia, ib)
        if far is not None and far[0] <= BACKGROUND_BOUND:
            return (f"the inpainted background's pixels differ by at most {far[0]:.2g} "
                    f"(bound {BACKGROUND_BOUND}), {far[1]} of {far[2]} pixels by more than "
                    "0.001, as the two OpenCV versions' cv::inpaint fills")
    return None


def background_difference(port, apt, ia, ib):
    """(largest difference of a channel, pixels differing by more than 0.001, pixels)
    between the two runs' kept background pixels; None when either run kept none."""
    import numpy as np
    try:
        a, b = (np.fromfile(os.path.join(d.get("_dir", ""), i["pixels_file"]), np.float32)
                for d, i in ((port, ia), (apt, ib)))
    except (KeyError, OSError):
        return None
    if a.size != b.size or a.size % 4:
        return None
    d = np.abs(a - b).reshape(-1, 4)
    if not np.isfinite(d).all():
        return None
    return float(d.max()), int((d.max(1) > 1e-3).sum()), len(d)


def items(d):
    return sum(len(d.get(g, {})) for g in ("hashes", "caches", "counts"))


def main(argv):
    opencv_differs = "--opencv-differs" in argv
    argv = [a for a in argv if a != "--opencv-differs"]
    if len(argv) != 3:
        sys.exit(__doc__)
    with open(argv[1]) as f:
        port = json.load(f)
    with open(argv[2]) as f:
        apt = json.load(f)
    port["_dir"], apt["_dir"] = (os.path.dirname(os.path.abspath(a)) for a in argv[1:3])
    notes = []
    bad = compare(port, apt, opencv_differs, notes)
    for line in notes:
        print("note " + line)
    for line in bad:
        print("FAIL " + line)
    total = max(items(port), items(apt))
    print(f"compared {total} hashes, caches and counts of Blender {port.get('blender')}: "
          f"{'equal' if not bad else 'different'}")
    print(f"{max(total - len(bad), 0)} passed, {len(bad)} failed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
