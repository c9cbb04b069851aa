"""How a part that came up with the target is held: it *hangs* from it or *rides* on it.

Both make the pick *tangled*; the difference says whether the CNN is learning entanglement
(a hook through a ring) or stacking (a part lying across the target). The rule, evaluated
at the end of the lift on the contacts between the part and the lifted cluster (the target
and the other parts still up):

- **rides**: the cluster pushes on the part only below its centre of mass: it rests on top;
- **hangs**: the force-weighted mean height of those contacts is at or above its centre of
  mass less ``SIDEWAYS_TOLERANCE_M``: it is hooked, interlocked, or pinched sideways, and
  would stay attached if the target were turned over;
- **dropped**: no contact with the cluster any more (it came up, then fell off or landed
  elsewhere); it still counts as lifted.
"""

from __future__ import annotations

from enum import Enum

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Body
from pydrake.systems.framework import Context

SIDEWAYS_TOLERANCE_M = 0.001


class Support(Enum):
    HANGS = "hangs"
    RIDES = "rides"
    DROPPED = "dropped"


def classify_support(plant: MultibodyPlant, plant_context: Context, bodies: list[Body],
                     target: int, still_up: list[int]) -> dict[int, Support]:
    """Support of each part in ``still_up`` (pile indices) by the lifted cluster."""
    if not still_up:
        return {}
    pile_index = {int(body.index()): n for n, body in enumerate(bodies)}
    cluster = {target, *still_up}
    heights: dict[int, list[float]] = {n: [] for n in still_up}
    weights: dict[int, list[float]] = {n: [] for n in still_up}
    results = plant.get_contact_results_output_port().Eval(plant_context)
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        a = pile_index.get(int(info.bodyA_index()))
        b = pile_index.get(int(info.bodyB_index()))
        if a is None or b is None:
            continue
        for part, other in ((a, b), (b, a)):
            if part in heights and other in cluster:
                heights[part].append(float(info.contact_point()[2]))
                weights[part].append(float(np.linalg.norm(info.contact_force())))
    support = {}
    for n in still_up:
        if not heights[n]:
            support[n] = Support.DROPPED
            continue
        w = np.asarray(weights[n])
        mean = float(np.average(heights[n], weights=w if w.sum() > 0 else None))
        z_com = bodies[n].EvalPoseInWorld(plant_context).translation()[2]
        support[n] = Support.RIDES if mean < z_com - SIDEWAYS_TOLERANCE_M else Support.HANGS
    return support
