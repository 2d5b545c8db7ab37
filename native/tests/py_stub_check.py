"""addon/_tussock.pyi against the built module (run by ./build.sh test: PYTHONPATH=build/release
python3 native/tests/py_stub_check.py): the stub tools/gen_pyi.py makes from the module now
must be the checked-in one, and it must name every function the module exports.
Prints 'N passed, N failed' last."""
import ast
import os
import sys

import _tussock

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tools"))
import gen_pyi  # noqa: E402

from pycheck import check, finish  # noqa: E402


text = gen_pyi.generate(_tussock)
with open(gen_pyi.STUB) as f:
    stub = f.read()
check(text == stub, "addon/_tussock.pyi is what tools/gen_pyi.py makes from the module "
      "(run python3 tools/gen_pyi.py)")
tree = ast.parse(stub)
defs = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
exported = {n for n in dir(_tussock) if not n.startswith("_") and n != "Error"}
check(defs == exported, "stub and module name the same functions: %s" % sorted(defs ^ exported))
check(len(defs) >= 90, "%d functions" % len(defs))
classes = {n.name for n in tree.body if isinstance(n, ast.ClassDef)}
check({"Error", "Handle"} <= classes, "classes %s" % classes)
finish()
