"""Random piles: drop the station's parts into the bin and simulate until they are at rest.

:func:`settle_pile` (once) and :class:`PileSettler` (pile after pile on one station) are the
episode's first half, used by every command that makes a pile; the second half, picking, is
:mod:`tangle_drake.episode.run`.

Parts are placed one by one at random poses above the bin, each checked against the bin and
the parts already placed with SceneGraph's penetration query, so nothing starts interpenetrating.
After settling, parts that ended outside the bin or deeply inside another are dropped again;
whatever still fails after ``max_redraws`` rounds is parked on the ground beside the robot and
reported, never silently left in the bin.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh
from pydrake.common.eigen_geometry import Quaternion
from pydrake.geometry import GeometryId, QueryObject
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Body
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.parts import PartModel, load_part
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.scenario import BinConfig, PileConfig, Scenario
from tangle_drake.station import SimulatedStation
from tangle_drake.station.bin_model import inside_bin

_CHECK_PERIOD = 0.05  # s of simulated time between rest checks
_REST_CHECKS = 2  # consecutive checks at rest before the pile counts as settled
_PLACEMENT_TRIES = 40  # random poses tried per height band before raising the band
_BAND_HEIGHT = 0.03  # m, height of the band a part's centre is drawn from


@dataclass
class PileReport:
    """What happened while making one pile."""

    seed: int
    num_parts: int
    settle_time: float = 0.0
    """Simulated seconds spent settling, all rounds together."""
    wall_time: float = 0.0
    redrawn: list[str] = field(default_factory=list)
    """Parts that were dropped again after ending outside the bin or interpenetrating."""
    parked: list[str] = field(default_factory=list)
    """Parts that still failed after every redraw and were taken out of the bin."""
    max_penetration: float = 0.0
    settled: bool = False
    """False if the time cap was reached before every part came to rest."""

    @property
    def num_in_bin(self) -> int:
        return self.num_parts - len(self.parked)


BULK = 1.7
"""The volume a part takes up in a loose pile, in convex hulls of the part: the top camera's
view of settled piles of 100 in the 20 x 28 cm bin measured 1.1 (S-hook, C-ring) to 1.7
(E-shape) (``tools/bin_fill.py``); the largest, so a warning errs toward caution."""
OVERFULL = 5.0
"""A pile estimated to fill more than this many wall heights is refused: it would spill over."""
GRIP_FRICTION = 0.9
"""The finger pads' friction coefficient (the gripper model's): what the grip can hold."""


def largest_radius(pile: PileConfig) -> float:
    """The largest bounding radius among the pile's parts, m: how far a part reaches."""
    return max(load_part(entry.part, mesh_scale=entry.mesh_scale).bounding_radius
               for entry in pile.parts)


def hull_volume(part: PartModel) -> float:
    """The volume of the part's convex hull, m³ (a part encloses a volume: ``load_part``
    refuses a flat or open mesh)."""
    return float(trimesh.load(part.visual_mesh_path, force="mesh").convex_hull.volume)


def check_pile(scenario: Scenario, spec: GripperSpec = DEFAULT_GRIPPER) -> list[str]:
    """Before any simulation: refuse a pile that cannot be made or picked (a part larger than
    the bin, or heavier than the fingers can hold, or far more parts than the bin holds), with
    the numbers; return a warning for a pile whose top parts would rise above the walls (its
    estimated fill height, :data:`BULK` convex hulls a part, plus a part's bounding radius)."""
    bin_config = scenario.bin
    half_diagonal = float(np.hypot(*bin_config.inner_size)) / 2
    liftable = 2 * GRIP_FRICTION * spec.grip_force / 9.81  # kg, two pads
    volume, reach = 0.0, 0.0
    for entry in scenario.pile.parts:
        if entry.count == 0:
            continue
        part = load_part(entry.part, mesh_scale=entry.mesh_scale)
        if part.bounding_radius > half_diagonal:
            raise TangleDrakeError(
                f"part {part.name!r} is too large for the bin: it reaches "
                f"{part.bounding_radius:.3f} m from its centre, the bin's floor only "
                f"{half_diagonal:.3f} m from its centre (check --mesh-scale: metres per mesh "
                "unit)")
        if part.mass > liftable:
            raise TangleDrakeError(
                f"part {part.name!r} weighs {part.mass:.2f} kg, more than the gripper's "
                f"{spec.grip_force:g} N fingers can hold ({liftable:.2f} kg)")
        volume += entry.count * BULK * hull_volume(part)
        reach = max(reach, part.bounding_radius)
    fill = volume / float(np.prod(bin_config.inner_size))
    wall = bin_config.wall_height
    if fill > OVERFULL * wall:
        raise TangleDrakeError(
            f"the pile of {scenario.pile.total_count} parts would fill the bin about "
            f"{100 * fill:.0f} cm deep, {fill / wall:.1f} times its {100 * wall:.0f} cm walls: "
            "use fewer parts or a larger bin")
    if fill + reach > wall:
        return [f"warning: the pile of {scenario.pile.total_count} parts would fill the bin "
                f"about {100 * fill:.1f} cm deep, its top parts reaching about "
                f"{100 * (fill + reach):.1f} cm, above the bin's {100 * wall:.0f} cm walls: "
                "they may fall out, and settling takes longer"]
    return []


@dataclass(frozen=True)
class SettledPile:
    """A pile at rest: the station plant's positions and velocities, and how it went."""

    state: np.ndarray
    report: PileReport


def settle_pile(station: SimulatedStation, scenario: Scenario, seed: int | None = None,
                progress: Callable[[str], None] | None = None) -> SettledPile:
    """Drop a pile (``seed``, else the scenario's) in ``station`` with its drivers holding
    still, and simulate until it rests. The same seed on the same station gives the same pile."""
    return PileSettler(station, scenario).settle(seed, progress)


class PileSettler:
    """Drops pile after pile into a station with its drivers holding still, each from the
    station's initial state, so a pile depends on its seed alone and not on the piles before
    it. After :meth:`settle`, ``simulator`` holds the settled pile (to render it, or to go on)."""

    def __init__(self, station: SimulatedStation, scenario: Scenario) -> None:
        self.scenario = scenario
        self.station = station
        self.simulator = Simulator(station)
        context = self.simulator.get_mutable_context()
        station.hold_still(context)
        self.simulator.Initialize()
        self.initial = context.Clone()
        """The station's state before any pile: what each :meth:`settle` starts from."""

    def settle(self, seed: int | None = None,
               progress: Callable[[str], None] | None = None) -> SettledPile:
        """A settled pile made with ``seed`` (default: the scenario's ``pile.seed``)."""
        self.simulator.get_mutable_context().SetTimeStateAndParametersFrom(self.initial)
        self.simulator.Initialize()
        report = _drop(self.simulator, self.station, self.scenario.bin, self.scenario.pile,
                       seed, progress)
        return SettledPile(self.station.plant_state(self.simulator.get_context()), report)


def _drop(simulator: Simulator, station: SimulatedStation, bin_config: BinConfig,
          pile_config: PileConfig, seed: int | None,
          progress: Callable[[str], None] | None) -> PileReport:
    """Make a settled random pile in ``simulator``'s context (of ``station``, whose command
    inputs hold still)."""
    seed = pile_config.seed if seed is None else seed
    plant = station.plant
    root = simulator.get_mutable_context()
    bodies = station.pile_bodies
    report = PileReport(seed=seed, num_parts=len(bodies))
    start = time.perf_counter()
    rng = np.random.default_rng(seed)

    margin = largest_radius(pile_config) if pile_config.drop_inside_walls else 0.0
    placer = _Placer(plant, root, bin_config, bodies, margin)
    placer.stage(bodies)
    to_drop = list(bodies)
    for round_index in range(pile_config.max_redraws + 1):
        for k in rng.permutation(len(to_drop)):
            placer.place(to_drop[k], rng)
        if progress:
            progress(f"settling {len(to_drop)} part(s), round {round_index + 1}")
        settled, duration = _settle(simulator, plant, bodies, pile_config)
        report.settle_time += duration
        report.settled = settled
        failed = _failed_parts(plant, placer, bodies, bin_config, pile_config, report)
        if not failed:
            break
        names = [plant.GetModelInstanceName(b.model_instance()) for b in failed]
        if round_index == pile_config.max_redraws:
            placer.park(failed)
            report.parked = names
            _settle(simulator, plant, bodies, pile_config)
            break
        report.redrawn.extend(names)
        placer.stage(failed)
        to_drop = failed
    report.wall_time = time.perf_counter() - start
    return report


class _Placer:
    """Places parts at collision-free random poses above the bin (or out of the way)."""

    def __init__(self, plant: MultibodyPlant, root: Context,
                 bin_config: BinConfig, bodies: list[Body], margin_above_rim: float) -> None:
        self.plant = plant
        self.margin_above_rim = margin_above_rim
        """A part placed higher than the rim keeps its centre this far inside the walls."""
        self.root = root
        self.context = plant.GetMyMutableContextFromRoot(root)
        self.bin = bin_config
        self.query_port = plant.get_geometry_query_input_port()
        self.owner: dict[GeometryId, Body] = {}
        for body in bodies:
            for geometry in plant.GetCollisionGeometriesForBody(body):
                self.owner[geometry] = body
        self.bodies = bodies

    def stage(self, bodies: list[Body]) -> None:
        """Move parts far apart, far away, so unplaced parts touch nothing."""
        for body in bodies:
            index = self.bodies.index(body)
            self._set(body, RigidTransform([50.0 + index, 50.0, 10.0]))

    def park(self, bodies: list[Body]) -> None:
        """Lay parts that cannot be placed in the bin on the ground, behind the robot."""
        for body in bodies:
            index = self.bodies.index(body)
            self._set(body, RigidTransform([-1.5, -1.0 + 0.2 * index, 0.05]))

    def place(self, body: Body, rng: np.random.Generator) -> None:
        half = np.asarray(self.bin.inner_size) / 2
        center = np.asarray(self.bin.center)
        low = self.bin.floor_height + 0.01
        rim = self.bin.floor_height + self.bin.wall_height
        inside = np.clip(1 - self.margin_above_rim / half, 0.0, 1.0)
        for band in range(200):
            for _ in range(_PLACEMENT_TRIES):
                xy = rng.uniform(-half, half)
                z = low + (band + rng.uniform()) * _BAND_HEIGHT
                xy = center + (xy * inside if z > rim else xy)
                rotation = RotationMatrix(_random_quaternion(rng))
                self._set(body, RigidTransform(rotation, [xy[0], xy[1], z]))
                if not self._collides(body):
                    return
        raise RuntimeError("could not find a free pose above the bin for a pile part")

    def _set(self, body: Body, X_WB: RigidTransform) -> None:
        self.plant.SetFreeBodyPose(self.context, body, X_WB)
        self.plant.SetFreeBodySpatialVelocity(self.context, body, SpatialVelocity.Zero())

    def _collides(self, body: Body) -> bool:
        query: QueryObject = self.query_port.Eval(self.context)
        for pair in query.ComputePointPairPenetration():
            if self.owner.get(pair.id_A) is body or self.owner.get(pair.id_B) is body:
                return True
        return False

    def penetration_by_body(self) -> dict[int, float]:
        """Deepest penetration each part is involved in, keyed by body index."""
        query: QueryObject = self.query_port.Eval(self.context)
        depth: dict[int, float] = {}
        for pair in query.ComputePointPairPenetration():
            for geometry in (pair.id_A, pair.id_B):
                body = self.owner.get(geometry)
                if body is not None:
                    key = int(body.index())
                    depth[key] = max(depth.get(key, 0.0), pair.depth)
        return depth


def _settle(simulator: Simulator, plant: MultibodyPlant, bodies: list[Body],
            config: PileConfig) -> tuple[bool, float]:
    """Advance until every part rests for a while or the time cap; (settled, seconds)."""
    context = plant.GetMyContextFromRoot(simulator.get_context())
    start = simulator.get_context().get_time()
    at_rest = 0
    while simulator.get_context().get_time() - start < config.settle_time_max:
        simulator.AdvanceTo(simulator.get_context().get_time() + _CHECK_PERIOD)
        speeds = [_speed(plant, context, body) for body in bodies]
        at_rest = at_rest + 1 if max(speeds, default=0.0) < config.settle_speed else 0
        if at_rest >= _REST_CHECKS:
            return True, simulator.get_context().get_time() - start
    return False, simulator.get_context().get_time() - start


def _speed(plant: MultibodyPlant, context: Context, body: Body) -> float:
    """A part's speed, its spin counted at the tip of a 5 cm lever, m/s."""
    velocity = body.EvalSpatialVelocityInWorld(context)
    return max(np.linalg.norm(velocity.translational()),
               0.05 * np.linalg.norm(velocity.rotational()))


def _failed_parts(plant: MultibodyPlant, placer: _Placer, bodies: list[Body],
                  bin_config: BinConfig, config: PileConfig, report: PileReport) -> list[Body]:
    context = placer.context
    depth = placer.penetration_by_body()
    report.max_penetration = max(depth.values(), default=0.0)
    failed = []
    for body in bodies:
        p_WB = body.EvalPoseInWorld(context).translation()
        if not inside_bin(bin_config, p_WB, margin=0.0) or \
                depth.get(int(body.index()), 0.0) > config.max_penetration:
            failed.append(body)
    return failed


def _random_quaternion(rng: np.random.Generator) -> Quaternion:
    """Uniformly distributed orientation (normalised 4-D Gaussian)."""
    q = rng.normal(size=4)
    return Quaternion(q / np.linalg.norm(q))
