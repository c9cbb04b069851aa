"""Simulation only: which parts the gripper holds up, counted along the load path.

Height alone (:class:`~tangle_drake.pick.outcome.LiftMonitor`) counts a part hanging above the
rim; it cannot tell a part held by the gripper from one flung past it, nor see that a second
part hooked on the target still rests partly on the pile, which makes the wrist read light.
This monitor follows the contacts instead: a part is **held** when a chain of part-to-part
contacts links it to the gripper's bodies, and **resting** when it is held and also touches
something else (the bin, the ground, the robot). It reads ``sim.contact_results``, a port no
controller may use; the planner records both counts at the first weighing as the truth the
estimator's verdict is scored against (several read as one is the dangerous error).
"""

from __future__ import annotations

from collections import defaultdict

from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import ContactResults, MultibodyPlant
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from tangle_drake.station import part_bodies

GRIPPER_BODY = "gripper_base"
"""A body of the gripper's model; every body of that model counts as the gripper."""


class LoadPathMonitor(LeafSystem):
    """Input ``contact_results`` (the station's ``sim.contact_results``); output
    ``held_count``, a 2-vector: parts held up by the gripper through contacts, and of those,
    parts also touching anything but the gripper and held parts."""

    def __init__(self, plant: MultibodyPlant, gripper_body: str = GRIPPER_BODY) -> None:
        super().__init__()
        self._parts = frozenset(int(body.index()) for body in part_bodies(plant))
        instance = plant.GetBodyByName(gripper_body).model_instance()
        self._gripper = frozenset(int(i) for i in plant.GetBodyIndices(instance))
        self._body_of = {geometry: i for i in range(plant.num_bodies())
                         for geometry in plant.GetCollisionGeometriesForBody(
                             plant.get_body(BodyIndex(i)))}
        self._contacts = self.DeclareAbstractInputPort(
            "contact_results", AbstractValue.Make(ContactResults()))
        self.DeclareVectorOutputPort("held_count", 2, self._calc_count)

    @property
    def gripper_bodies(self) -> frozenset[int]:
        """Body indices of the gripper's model."""
        return self._gripper

    def touching(self, results: ContactResults) -> dict[int, set[int]]:
        """Body index -> body indices it touches, from point and hydroelastic contacts."""
        pairs = [(int(info.bodyA_index()), int(info.bodyB_index()))
                 for info in (results.point_pair_contact_info(i)
                              for i in range(results.num_point_pair_contacts()))]
        for i in range(results.num_hydroelastic_contacts()):
            surface = results.hydroelastic_contact_info(i).contact_surface()
            a, b = self._body_of.get(surface.id_M()), self._body_of.get(surface.id_N())
            if a is not None and b is not None:
                pairs.append((a, b))
        graph: dict[int, set[int]] = defaultdict(set)
        for a, b in pairs:
            graph[a].add(b)
            graph[b].add(a)
        return graph

    def held_parts(self, context: Context) -> tuple[set[int], set[int]]:
        """Body indices of the parts held now, and of those resting on something else."""
        return held_and_resting(self.touching(self._contacts.Eval(context)), self._parts,
                                self._gripper)

    def _calc_count(self, context: Context, output: BasicVector) -> None:
        held, resting = self.held_parts(context)
        output.SetFromVector([len(held), len(resting)])


def held_and_resting(touching: dict[int, set[int]], parts: frozenset[int],
                     gripper: frozenset[int]) -> tuple[set[int], set[int]]:
    """The ``parts`` linked to a ``gripper`` body by a chain of touching parts, and of those
    the ones touching anything that is neither a part nor the gripper."""
    held: set[int] = set()
    frontier = [b for g in gripper for b in touching.get(g, ()) if b in parts]
    while frontier:
        body = frontier.pop()
        if body not in held:
            held.add(body)
            frontier.extend(b for b in touching[body] if b in parts and b not in held)
    resting = {b for b in held
               if any(o not in parts and o not in gripper for o in touching[b])}
    return held, resting
