"""The module map of docs/architecture.md, made from the code: every module of the add-on (its
docstring's first paragraph) and of the native library, its public headers, benchmarks,
fuzzers and tests (the first paragraph of each file's opening comment), grouped by folder.
The map sits between the marker lines; a module added, moved or removed changes it, and
tests/test_module_map.py fails until it is remade, so the document cannot fall behind:

  python3 tools/module_map.py write     remake the map in docs/architecture.md
  python3 tools/module_map.py check     exit 1 when the map is not what the code gives

Plain Python (ast, no import of the modules, so no bpy): ./build.sh runs it with the system
Python."""

import ast
import os
import re
import subprocess
import sys

import generated_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "architecture.md")
BEGIN, END = "<!-- module-map -->", "<!-- /module-map -->"
# (folder pattern, file pattern): what counts as a module
PARTS = (
    ("addon", r".*\.py$"),
    ("native/include", r".*\.h$"),
    ("native/src", r".*\.(c|cpp|h)$"),
    ("native/helpers", r".*\.(c|cpp)$"),
    ("native/bench", r".*\.(c|h)$"),
    ("native/fuzz", r"[^/]*\.(c|cpp|h)$"),
    ("native/tests", r".*\.(c|h|py)$"),
    ("tests", r".*\.py$"),
    ("blender_tests", r".*\.py$"),
    ("tools", r".*\.py$"),
)
WIDTH = 160  # characters of a summary in the table


def tracked_files():
    """The files git tracks (so a stray build product never enters the map); every file
    under the folders when git is missing."""
    try:
        out = subprocess.run(["git", "-C", ROOT, "ls-files"], text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, check=True)
        return sorted(out.stdout.split())
    except (OSError, subprocess.CalledProcessError):
        files = []
        for folder, _ in PARTS:
            for d, _, names in os.walk(os.path.join(ROOT, folder)):
                files += [os.path.relpath(os.path.join(d, n), ROOT) for n in names]
        return sorted(files)


def first_paragraph(text):
    para = text.strip().split("\n\n")[0]
    para = re.sub(r"\s+", " ", para).strip()
    if len(para) > WIDTH:
        cut = para[:WIDTH]
        end = cut.rfind(". ")
        para = cut[:end + 1] if end > WIDTH // 2 else cut.rsplit(" ", 1)[0].rstrip(",;:") + " …"
    return para


def summary(path):
    with open(os.path.join(ROOT, path), encoding="utf-8", errors="replace") as f:
        text = f.read()
    if path.endswith(".py"):
        try:
            doc = ast.get_docstring(ast.parse(text))
        except SyntaxError:
            doc = None
        return first_paragraph(doc) if doc else ""
    m = re.match(r"\s*/\*(.*?)\*/", text, re.S) or re.match(r"\s*((?://[^\n]*\n)+)", text)
    if not m:
        return ""
    body = re.sub(r"^\s*(\*|//)\s?", "", m.group(1), flags=re.M)
    return first_paragraph(body)


def modules(files=None):
    """[(folder, [(file name, summary)])] in PARTS order, folders sorted within a part."""
    files = tracked_files() if files is None else files
    groups = {}
    for folder, pattern in PARTS:
        for f in files:
            if not f.startswith(folder + "/"):
                continue
            rel = f[len(folder) + 1:]
            if not re.fullmatch(pattern, rel) or "/corpus/" in f or "/__pycache__/" in f:
                continue
            d = os.path.dirname(f)
            groups.setdefault(d, []).append((os.path.basename(f), summary(f)))
    order = [folder for folder, _ in PARTS]

    def key(d):
        part = next(i for i, p in enumerate(order) if d == p or d.startswith(p + "/"))
        return (part, d)
    return [(d, sorted(groups[d])) for d in sorted(groups, key=key)]


def render(groups):
    out = []
    for d, items in groups:
        out.append(f"**`{d}/`**\n")
        out.append("| module | what it is |")
        out.append("| --- | --- |")
        for name, text in items:
            out.append(f"| `{name}` | {text.replace('|', '/') or '—'} |")
        out.append("")
    return "\n".join(out).rstrip()


def render_doc(text, body):
    return generated_block.splice(text, BEGIN, END, body, DOC)


def undocumented(groups):
    """Modules without an opening docstring or comment: each must say what it is."""
    return [f"{d}/{n}" for d, items in groups for n, t in items if not t]


def main(argv):
    cmd = argv[1] if len(argv) > 1 else "check"
    if cmd not in ("write", "check"):
        print(__doc__, file=sys.stderr)
        return 2
    return generated_block.write_or_check(
        cmd, DOC, lambda text: render_doc(text, render(modules())),
        "docs/architecture.md: the module map is not what the code gives; run "
        "`python3 tools/module_map.py write`")


if __name__ == "__main__":
    sys.exit(main(sys.argv))
