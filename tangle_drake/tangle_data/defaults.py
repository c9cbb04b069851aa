"""Default pile sizes: how many parts make a real pile (about three layers deep) per part.

Measured in the data scenario's 0.16 x 0.20 m bin (``tools/bench_collect.py`` prints the
depth of every pile it makes; :mod:`.pile_stats` defines layers). A user's mesh part gets a
count from its size: enough parts to cover the bin's floor one and a half times when lying
flat, which piles them two to four layers deep.
"""

from __future__ import annotations

import numpy as np
import trimesh

from tangle_drake.parts import PartModel
from tangle_drake.scenario import BinConfig

BUILTIN_PARTS_PER_PILE: dict[str, int] = {
    "u_hook": 18,
    "s_hook": 18,
    "c_ring": 20,
    "j_hook": 14,
    "e_shape": 14,
}
MESH_FLOOR_COVER = 1.5
MESH_PARTS_RANGE = (4, 40)


def default_parts_per_pile(name: str, part: PartModel, bin_config: BinConfig) -> int:
    """The table's count for a built-in part, else one from the part's flat footprint."""
    if name in BUILTIN_PARTS_PER_PILE:
        return BUILTIN_PARTS_PER_PILE[name]
    mesh = trimesh.load(part.visual_mesh_path, force="mesh", process=False)
    extents = np.sort(mesh.bounding_box_oriented.primitive.extents)
    footprint = float(extents[1] * extents[2])
    count = MESH_FLOOR_COVER * float(np.prod(bin_config.inner_size)) / footprint
    return int(np.clip(round(count), *MESH_PARTS_RANGE))
