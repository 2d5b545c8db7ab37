"""The soak tester's own test (issue 42), with the machine's Blender: a planted operator that
raises in 1 call of 50 is found, shrunk to at most 5 steps and reported with its seed; a
planted frame handler that leaks a mesh per frame is found; a planted step that leaves
Blender's blocks at exit is found with --debug-memory and shrunk to that step, while the
blocks Blender leaves by itself are no failure; memory that no data-block holds is told from
a large scene, also with the output folder given as a relative path; a short clean soak of
the add-on passes. Run by ./build.sh test, or alone: /usr/bin/python3 tests/test_soak.py
[NAME...]"""

import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
SOAK = os.path.join(HERE, "..", "tools", "soak.py")
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tools"))
import harness  # noqa: E402
import soak as soak_tool  # noqa: E402

# steps that take milliseconds: the planted fault comes up within seconds
FAST = "planted,frame_set,play,rename,add_wind_source,duplicate,delete,undo,redo,set_prop"


def soak(*args, plant=""):
    """Runs tools/soak.py; returns (exit status, output)."""
    env = dict(os.environ, TSK_SOAK_PLANT=plant)
    with tempfile.TemporaryDirectory(prefix="tsk_soak_test_") as out:
        proc = subprocess.run(["/usr/bin/python3", SOAK, "--out", out, "--max-failures", "1",
                               *args], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, errors="replace",
                              timeout=600)
    return proc.returncode, proc.stdout


def summary(text):
    m = re.search(r"^soak: (\d+) steps in (\d+) s(?: soaking \(\d+ s in all\))?, seed (\d+), "
                  r"(\d+) failures", text, re.M)
    assert m, text[-3000:]
    return tuple(int(x) for x in m.groups())


def shrunk_steps(text):
    m = re.search(r"^soak: \d+ steps shrunk to (\d+):\n((?:  \{.*\n)+)", text, re.M)
    assert m, text[-3000:]
    return int(m.group(1)), m.group(2).splitlines()


def test_planted_raise_is_found_shrunk_to_5_steps_and_reported_with_its_seed():
    code, text = soak("--seed", "7", "--steps", "400", "--only", FAST, plant="raise")
    assert code == 1, (code, text[-3000:])
    steps, _, seed, failures = summary(text)
    assert failures == 1 and seed == 7, text[-3000:]
    assert re.search(r"^soak: FAILURE with seed \d+: python-error", text, re.M), text[-3000:]
    count, lines = shrunk_steps(text)
    assert 1 <= count <= 5, (count, lines)
    assert any('"op": "planted", "n": 0' in line for line in lines), lines
    assert "ZeroDivisionError: the planted fault" in text, text[-3000:]
    print(f"  found after {steps} steps, shrunk to {count}")


def test_planted_leak_is_found():
    code, text = soak("--seed", "3", "--steps", "60", "--only", "add_tree,play,scrub,rename",
                      plant="leak")
    assert code == 1, (code, text[-3000:])
    assert re.search(r"^soak: FAILURE with seed 3: leak: .*'meshes'", text, re.M), text[-3000:]
    count, _ = shrunk_steps(text)
    assert count <= 5, count


def test_blocks_left_at_exit_are_found_and_shrunk_to_the_step_that_left_them():
    # no step reports them: only Blender's --debug-memory list at exit shows them
    code, text = soak("--seed", "7", "--steps", "150", "--debug-memory", "--only",
                      FAST.replace("planted", "planted_unfreed"), plant="unfreed")
    assert code == 1, (code, text[-3000:])
    m = re.search(r"^soak: FAILURE with seed 7: unfreed: (\d+) blocks not freed at exit",
                  text, re.M)
    assert m and int(m.group(1)) > 0, text[-3000:]
    assert "BM_mesh_create len: " in text, text[-3000:]
    count, lines = shrunk_steps(text)
    assert 1 <= count <= 5, (count, lines)
    assert '"op": "planted_unfreed", "n": 0' in lines[-1], lines
    print(f"  {m.group(1)} blocks, shrunk to {count} steps")


def exit_text(version, names):
    """What a --debug-memory Blender prints: its version first, its blocks at exit last."""
    blocks = "".join(f"{n} len: 4 0x7fe8deffd{i:03x}\n" for i, n in enumerate(names))
    return (f"Blender {version}\nRead prefs...\n{blocks}\nBlender quit\n"
            f"Error: Not freed memory blocks: {len(names)}, total unfreed memory 0.000290 MB\n")


def test_blocks_that_blender_leaves_by_itself_are_no_failure_and_any_other_is():
    join = "ED_mesh_join_objects_exec"  # Blender 4.3's Join, shown without the add-on
    assert soak_tool.blocks_left(exit_text("4.3.2", [join] * 23)) == (0, "")
    leaks, detail = soak_tool.blocks_left(exit_text("4.3.2", [join, "BM_mesh_create", join]))
    assert leaks == 3 and "2 of them Blender's own" in detail, detail
    assert "BM_mesh_create len: 4" in detail and join not in detail, detail
    # the same block from another Blender is not known to be Blender's own
    leaks, detail = soak_tool.blocks_left(exit_text("5.2.2 LTS", [join]))
    assert leaks == 1 and f"{join} len: 4" in detail, detail
    assert soak_tool.blocks_left("Blender 4.3.2\nBlender quit\n") == (0, "")


def test_memory_that_the_scene_does_not_explain_is_found():
    code, text = soak("--seed", "5", "--steps", "40", "--only", "add_tree,play,scrub,rename",
                      "--max-rss-mb", "700", "--shrink-minutes", "2", plant="hoard")
    assert code == 1, (code, text[-3000:])
    m = re.search(r"^soak: FAILURE with seed 5: memory: more memory than the scene explains: "
                  r"(\d+) MB before, (\d+) MB with the file opened again, a fresh Blender "
                  r"(\d+) MB", text, re.M)
    assert m, text[-3000:]
    before, here, fresh = (int(x) for x in m.groups())
    assert before > 700 and here > fresh + 400, m.group(0)


def test_a_scene_that_needs_the_memory_is_measured_and_replaced_by_a_new_file():
    # a bound below what Blender itself needs: every step is measured, none is a leak
    code, text = soak("--seed", "9", "--steps", "12", "--only", "add_tree,add_meadow,play",
                      "--max-rss-mb", "1")
    steps, _, _, failures = summary(text)
    assert code == 0 and failures == 0, (code, text[-5000:])
    found = re.findall(r"NEW FILE \((\d+) MB before, (\d+) MB with the file opened again, a "
                       r"fresh Blender (\d+) MB", text)
    assert len(found) >= 4, text[-3000:]
    for before, here, fresh in found:
        assert 0 < int(fresh) and int(here) <= 1.25 * int(fresh) + 400, found


def test_the_memory_step_saves_into_an_output_folder_given_as_a_relative_path():
    # Blender 3.4 refuses to save a file to a relative path: with `--out build/x` every
    # memory step failed there (the 3.4 hour in a window, seed 932506)
    with tempfile.TemporaryDirectory(prefix="tsk_soak_test_") as cwd:
        proc = subprocess.run(["/usr/bin/python3", SOAK, "--out", "out", "--max-failures", "1",
                               "--seed", "5", "--steps", "3", "--max-rss-mb", "1",
                               "--only", "add_wind_source,rename"],
                              cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True, errors="replace", timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:]
    assert re.search(r"^soak: memory at step \d+: NEW FILE", proc.stdout, re.M), \
        proc.stdout[-3000:]


def test_a_short_clean_soak_passes():
    code, text = soak("--seed", "11", "--steps", "40")
    steps, _, seed, failures = summary(text)
    assert code == 0 and failures == 0, (code, text[-5000:])
    assert steps == 40 and seed == 11, text[-2000:]


if __name__ == "__main__":
    sys.exit(harness.run(globals()))
