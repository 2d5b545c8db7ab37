"""`python3 <add-on folder>/farm ...`: the farm command (cli.py), without Blender. The
folder is loaded as a package of its own, so the add-on itself (which needs bpy) is not."""

import sys

if __package__ in (None, ""):
    import importlib.util
    import os
    here = os.path.dirname(os.path.abspath(__file__))
    spec = importlib.util.spec_from_file_location(
        "tussock_farm", os.path.join(here, "__init__.py"), submodule_search_locations=[here])
    package = importlib.util.module_from_spec(spec)
    sys.modules["tussock_farm"] = package
    spec.loader.exec_module(package)
    from tussock_farm import cli
else:
    from . import cli

sys.exit(cli.main())
