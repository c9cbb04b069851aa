"""The part library: built-in bent-wire parts and users' mesh files as Drake SDF models.

``load_part("u_hook")`` or ``load_part("bracket.stl", mesh_scale=0.001)`` returns a
`PartModel` whose files live in the content-addressed cache (``cache_dir()/parts``).
"""

from tangle_drake.parts.catalog import BUILTIN_PARTS
from tangle_drake.parts.library import PartModel, load_part

__all__ = ["BUILTIN_PARTS", "PartModel", "load_part"]
