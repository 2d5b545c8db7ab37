"""tools/artist_compare.py, which decides whether the portable zip on an artist's machine
computed what the apt build computed: every difference that matters fails it, and only an
EXR written in other bytes with equal pixels, or (with --opencv-differs) the picture's
inpainted background within its bound, passes. Run by ./build.sh test, or alone:
/usr/bin/python3 tests/test_artist_compare.py [NAME...]"""

import copy
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import artist_compare  # noqa: E402
import harness  # noqa: E402

BG = "tussock_cache/Scene_picture/background.exr"
LAYER = "tussock_cache/Scene_picture/layer_1.exr"
RESULT = {
    "ok": True, "blender": "5.2.2 LTS",
    "render": {"exists": True},
    "counts": {"simulated_blades": 1696, "blades_files": 5},
    "hashes": {"capture_files": "a1", "capture_oni": "a2", "sim_knots": "a3", "tree_mesh": "a4"},
    "caches": {"tussock_cache/Meadow_blades.pc2": "c1", BG: "c2", BG + ".tski": "c3",
               LAYER: "c4", LAYER + ".tski": "c5"},
    "images": {BG: {"pixels_sha256": "p1", "size": [480, 270]},
               LAYER: {"pixels_sha256": "p2", "size": [480, 270]}},
}


def changed(path, value):
    d = copy.deepcopy(RESULT)
    *keys, last = path
    node = d
    for k in keys:
        node = node[k]
    if value is None:
        del node[last]
    else:
        node[last] = value
    return d


def test_equal_results_pass():
    assert artist_compare.compare(RESULT, copy.deepcopy(RESULT)) == []


def test_any_skeleton_solver_tree_or_count_difference_fails():
    for path, value in ((("hashes", "capture_oni"), "zz"), (("hashes", "sim_knots"), "zz"),
                        (("hashes", "tree_mesh"), "zz"), (("counts", "blades_files"), 4),
                        (("hashes", "capture_files"), None)):
        bad = artist_compare.compare(changed(path, value), RESULT, opencv_differs=True)
        assert len(bad) == 1 and path[1] in bad[0], (path, bad)


def test_a_cache_with_other_bytes_fails_unless_its_pixels_are_equal():
    other = changed(("caches", "tussock_cache/Meadow_blades.pc2"), "zz")
    assert len(artist_compare.compare(other, RESULT, opencv_differs=True)) == 1
    notes = []
    rewritten = changed(("caches", LAYER), "zz")
    rewritten["caches"][LAYER + ".tski"] = "zz"
    assert artist_compare.compare(rewritten, RESULT, notes=notes) == []
    assert len(notes) == 2 and all("equal pixels" in n for n in notes), notes
    repainted = copy.deepcopy(rewritten)
    repainted["images"][LAYER]["pixels_sha256"] = "zz"
    assert len(artist_compare.compare(repainted, RESULT, opencv_differs=True)) == 2


def test_only_the_inpainted_background_may_differ_with_another_opencv_and_within_its_bound():
    import tempfile
    import numpy as np
    rng = np.random.default_rng(7)
    ref = rng.random(480 * 270 * 4, dtype=np.float32)
    bound = artist_compare.BACKGROUND_BOUND
    with tempfile.TemporaryDirectory() as d:
        def run(pixels, size=(480, 270), opencv_differs=True):
            os.makedirs(os.path.join(d, "a"), exist_ok=True)
            os.makedirs(os.path.join(d, "b"), exist_ok=True)
            ref.tofile(os.path.join(d, "b", "bg.f32"))
            bg = changed(("caches", BG), "zz")
            bg["caches"][BG + ".tski"] = "zz"
            bg["images"][BG].update(pixels_sha256="zz", size=list(size))
            if pixels is not None:
                pixels.astype(np.float32).tofile(os.path.join(d, "a", "bg.f32"))
                bg["images"][BG]["pixels_file"] = "bg.f32"
            apt = copy.deepcopy(RESULT)
            apt["images"][BG]["pixels_file"] = "bg.f32"
            bg["_dir"], apt["_dir"] = os.path.join(d, "a"), os.path.join(d, "b")
            notes = []
            bad = artist_compare.compare(bg, apt, opencv_differs=opencv_differs, notes=notes)
            return bad, notes
        near = ref.copy()
        near[100:4000:4] += 0.9 * bound
        assert len(run(near, opencv_differs=False)[0]) == 2
        bad, notes = run(near)
        assert bad == [] and len(notes) == 2 and "by at most" in notes[0], (bad, notes)
        far = ref.copy()
        far[4003] += 1.1 * bound  # one pixel's alpha beyond the bound
        assert len(run(far)[0]) == 2
        broken = near.copy()
        broken[8] = np.nan
        assert len(run(broken)[0]) == 2
        assert len(run(None)[0]) == 2  # no pixels kept: nothing to measure
        assert len(run(near, size=(480, 271))[0]) == 2


def test_a_run_that_failed_simulated_nothing_or_rendered_nothing_fails():
    for path, value, word in ((("ok",), False, "did not end well"),
                              (("counts", "simulated_blades"), 0, "simulated no blade"),
                              (("render", "exists"), False, "rendered no frame"),
                              (("blender",), "4.3.2", "not the same Blender")):
        bad = artist_compare.compare(changed(path, value), RESULT)
        assert any(word in b for b in bad), (path, bad)


def test_the_command_exits_1_and_prints_the_tally_on_a_difference():
    import json
    import subprocess
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        a, b = os.path.join(d, "a.json"), os.path.join(d, "b.json")
        with open(a, "w") as f:
            json.dump(RESULT, f)
        with open(b, "w") as f:
            json.dump(changed(("hashes", "sim_knots"), "zz"), f)
        tool = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools",
                            "artist_compare.py")
        p = subprocess.run([sys.executable, tool, a, b], capture_output=True, text=True)
        assert p.returncode == 1 and p.stdout.splitlines()[-1].endswith("1 failed"), p.stdout
        p = subprocess.run([sys.executable, tool, a, a], capture_output=True, text=True)
        assert p.returncode == 0 and p.stdout.splitlines()[-1].endswith("0 failed"), p.stdout


if __name__ == "__main__":
    sys.exit(harness.run(globals()))
