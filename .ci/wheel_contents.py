"""Run from outside the checkout with the installed wheel: every module of the package
imports, and every file the repository ships for it (models, model cards, scenarios) is in
the installed package. Argument: a file listing the repository's shipped paths."""

import importlib
import pkgutil
import sys
from pathlib import Path

import tangle_drake

package = Path(tangle_drake.__file__).parent
if "site-packages" not in package.parts:
    sys.exit(f"tangle_drake comes from {package}, not from the installed wheel")
# A package's __main__ runs its command when imported: it is run, not imported, by users.
modules = [info.name for info in pkgutil.walk_packages(tangle_drake.__path__, "tangle_drake.")
           if not info.name.endswith(".__main__")]
failed = []
for name in modules:
    try:
        importlib.import_module(name)
    except Exception as error:  # every failure is reported, not only the first
        failed.append(f"{name}: {type(error).__name__}: {error}")
# In the repository, models/ and diagrams/ sit at the top; the wheel maps them into the package.
missing = [path for path in Path(sys.argv[1]).read_text().split()
           if not (package / (path.removeprefix("tangle_drake/") if path.startswith(
               "tangle_drake/") else path)).is_file()]
for line in failed + [f"not in the wheel: {path}" for path in missing]:
    print(line)
print(f"{len(modules)} modules imported, {len(failed)} failed; "
      f"{len(Path(sys.argv[1]).read_text().split())} shipped files, {len(missing)} missing")
sys.exit(1 if failed or missing else 0)
