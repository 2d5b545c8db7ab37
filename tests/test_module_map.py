"""docs/architecture.md's module map is the one the code gives, and every module says what it
is (plain python3; tools/module_map.py)."""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import module_map  # noqa: E402
import harness  # noqa: E402


def test_every_module_says_what_it_is():
    groups = module_map.modules()
    names = {f"{d}/{n}" for d, items in groups for n, _ in items}
    for must in ("addon/compat.py", "native/src/sim/tiles.c", "native/include/tussock/sim.h",
                 "tools/module_map.py", "tests/test_module_map.py"):
        assert must in names, must
    assert len(names) > 200, len(names)
    assert module_map.undocumented(groups) == [], module_map.undocumented(groups)


def test_summaries_come_from_the_files():
    files = ["addon/compat.py", "native/src/bake/pc2.c", "addon/farm/__pycache__/x.py",
             "native/fuzz/corpus/sim/a.c"]
    groups = dict(module_map.modules(files))
    assert set(groups) == {"addon", "native/src/bake"}, groups  # caches and corpora are not modules
    assert groups["addon"][0][1].startswith("The few Blender API differences"), groups
    assert groups["native/src/bake"][0][1].startswith("Point Cache 2 (.pc2) files"), groups


def test_doc_map_is_what_the_code_gives():
    with open(module_map.DOC, encoding="utf-8") as f:
        text = f.read()
    new = module_map.render_doc(text, module_map.render(module_map.modules()))
    assert new == text, ("docs/architecture.md's module map is stale: "
                         "python3 tools/module_map.py write")


if __name__ == "__main__":
    sys.exit(harness.run(globals()))
