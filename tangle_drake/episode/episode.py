"""One episode shape for every simulated run of a scenario: a part's pile settler and pick
diagram, built once and run pile after pile. The demo, the benchmark's single picks and its
clearings, the physical-pick data and the tools all go through :class:`Episode`; what differs
between them is the planner's settings and the speed-ups, options of the episode. On
hardware (:meth:`Episode.on_hardware`) the same pick diagram is built around the hardware
station and run against the robot's drivers, or the hardware simulator in this process.

Each run restores a settled plant state into the diagram and runs it from the diagram's
initial state, so it depends on its pile alone (:class:`~.run.PickEpisode`). A single pick
(:meth:`Episode.single_pick`) keeps the pile's bodies locked until the robot reaches into the
bin: at rest and untouched, they cost the contact solver nothing (the approach is a fifth of
a floating pick), and unlocking them at the descent leaves them exactly where they lay.

A ``fast`` single pick (the physical-pick data's) takes two shortcuts. It ends a grasp whose
fingers closed on nothing at the close, judged empty as the top of the lift would judge it
(fingers closed past the empty width are empty whatever the lift does:
:func:`~tangle_drake.pick.outcome.classify_lift`), instead of lifting the empty gripper out:
the same outcome, without the lift's simulated seconds. And where the scenario freezes
nothing, it freezes the parts out of the grasp's reach from the descent on
(:data:`PICK_DATA_FREEZE_RADII`). Keeping the whole pile locked through the descent until the
fingers touch it was tried and dropped: a pile frozen for that second instead of creeping is
another pile, and it changed outcomes where moving the grasp a tenth of a millimetre did not
(``docs/data-and-training.md``, Measured).

The scenario's ``simulation`` settings speed every caller up alike: the pick diagram's plant
steps at ``pick_time_step`` (the pile is settled at the plant's own step), and with
``freeze_beyond_radii`` each grasp freezes the parts out of its reach
(:mod:`tangle_drake.station.pile_freeze`) from its descent on (a run: until the next grasp's
descent, or a shake, a put-back or a stir, which wake them; :func:`freeze_change`).
``tools/physics_agreement.py`` checks settings against the shipped ones, and (``--fast``) the
fast pick against the full one.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram

from tangle_drake.episode.run import (
    SIM_TIME_PER_PICK,
    Clock,
    PickEpisode,
    PickRun,
    RunEnd,
    run_picks,
)
from tangle_drake.hardware.hardware_sim import HardwareSim
from tangle_drake.hardware.loop import HardwareInTheLoop
from tangle_drake.lcm_io.buses import network_bus_url
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.pick.diagram import build_pick_diagram, closed_loop_settings, pick_settings
from tangle_drake.pick.outcome import Outcome, PickRecord, classify_lift
from tangle_drake.pick.planner import Mode, PickSettings
from tangle_drake.planning.motions import motion_for
from tangle_drake.scenario import Scenario
from tangle_drake.selection.methods import Method, MethodRun, selection_wiring
from tangle_drake.station import SimulatedStation, build_station, camera_model
from tangle_drake.station.bin_model import inside_bin
from tangle_drake.station.perturb import ContactScaler, PickPhysics
from tangle_drake.station.pile import PileSettler, SettledPile, largest_radius
from tangle_drake.station.pile_freeze import FREEZE_BEYOND_RADII, PileFreeze, parts_beyond

FLOATING_SIM_LIMIT = 20.0
"""Simulated seconds a floating-gripper pick may take: several times what one takes, so only a
pick that is stuck reaches it."""
_POLL = 0.05
"""Simulated seconds between checks whether the pick is over, s."""
_UNTOUCHED = (Mode.SETTLE, Mode.PERCEIVE, Mode.APPROACH)
"""Modes in which the robot does not reach into the bin: the settled pile stays locked."""
_WAKING = (Mode.SHAKE, Mode.PUT_BACK, Mode.STIR)
"""Modes that move loads or the gripper through the pile beyond a grasp's reach: they wake
every frozen part, and the pile stays awake until the next grasp's descent."""
PICK_DATA_FREEZE_RADII = FREEZE_BEYOND_RADII + 1
"""A physical-pick sample's freeze, in bounding radii from the grasp, where the scenario sets
none: the auto-lift labeller's rule measured from the target's centre, which lies within one
radius of the grasp."""


@dataclass(frozen=True)
class PhysicalPick:
    """What one pick did, and what it was chosen on."""

    record: PickRecord | None
    """The planner's record of the pick; ``None``: it did not finish in the time allowed."""
    sim_s: float
    """Simulated time the pick took, s."""
    depth: np.ndarray
    """The top camera's depth image the grasp was chosen on, (H, W) metres."""


class Episode:
    """A part's pile settler and pick diagram, built once and run pile after pile.

    ``methods`` are the diagram's (its ``method`` input switches between them), ``part`` finds
    their shipped models, ``settings`` are the planner's. ``lock_until_descent`` keeps the
    settled pile locked until the robot reaches into the bin, and ``fast`` takes the
    physical-pick data's shortcuts (see the module docstring; single picks only).
    """

    def __init__(self, scenario: Scenario, methods: Sequence[Method], part: str | None,
                 settings: PickSettings, *, station: Diagram | None = None,
                 fixed: MethodRun | None = None, return_home: bool = True,
                 lock_until_descent: bool = False, fast: bool = False,
                 sim_limit: float = SIM_TIME_PER_PICK, meshcat: Meshcat | None = None) -> None:
        station = station or build_station(picking(scenario), meshcat)
        pick = build_pick_diagram(
            scenario, motion_for(scenario, return_home=return_home),
            selection_wiring(methods, part, scenario, fixed), station=station,
            settings=settings)
        self.scenario = scenario
        self.pick_diagram = pick
        self.robot: HardwareSim | None = None
        """With the hardware simulator in this process (:meth:`on_hardware`): the robot side."""
        self.methods = {m.name: m for m in methods}
        self._reach: float | None = None
        """Parts whose centre lies farther than this from a grasp are frozen while it is made
        (``None``: none, and always on hardware), m."""
        if not isinstance(station, SimulatedStation):
            return  # on hardware: :meth:`on_hardware` sets the clock
        self.settler = PileSettler(build_station(scenario, meshcat), scenario)
        self.episode = PickEpisode(pick)
        self.clock: Clock = self.episode.simulator
        self.sim_limit = sim_limit
        self.update_period = settings.update_period
        """The planner's: while the pile is locked, the driver looks at every update."""
        self.lock_until_descent = lock_until_descent
        self.fast = fast
        self.empty_width = settings.empty_width
        self.intrinsics: CameraIntrinsics = camera_model(scenario).intrinsics
        self._contacts = ContactScaler(station.plant, station.scene_graph)
        self._bin = scenario.bin
        self._freeze = PileFreeze(station.plant, station.scene_graph, station.pile_bodies)
        radii = scenario.simulation.freeze_beyond_radii or (PICK_DATA_FREEZE_RADII if fast
                                                            else None)
        if radii is not None:
            self._reach = radii * largest_radius(scenario.pile)

    @classmethod
    def on_hardware(cls, scenario: Scenario, method: Method, settings: PickSettings,
                    run: MethodRun, *, with_hardware_sim: bool, seed: int | None = None,
                    say: Callable[[str], None] = print) -> Episode:
        """The pick diagram around the hardware station, selecting as ``run`` says: against
        the hardware simulator in this process over ``memq://`` (``with_hardware_sim``, its
        pile made with ``seed``), or against the robot's drivers on the scenario's LCM bus in
        real time (this waits for the robot's first messages). Run it with :meth:`run`."""
        if with_hardware_sim:
            built: list[Episode] = []

            def make(station: Diagram) -> Diagram:
                built.append(cls(scenario, [method], None, settings, station=station,
                                 fixed=run))
                return built[0].pick_diagram.diagram

            loop = HardwareInTheLoop(scenario, make, seed, progress=say)
            episode = built[0]
            episode.clock, episode.robot = loop, loop.robot
            return episode
        url = network_bus_url(scenario, "use --with-hardware-sim to run against the hardware "
                                        "simulator in this process")
        station = build_station(scenario, hardware=True)
        episode = cls(scenario, [method], None, settings, station=station, fixed=run)
        simulator = Simulator(episode.pick_diagram.diagram)
        simulator.set_target_realtime_rate(1.0)
        say(f"waiting for the robot on {url} ...")
        station.initialize(simulator)
        episode.clock = simulator
        return episode

    @classmethod
    def single_pick(cls, scenario: Scenario, methods: Sequence[Method], part: str,
                    floating: bool, fast: bool = False) -> Episode:
        """One pick per run, the benchmark's and the physical-pick data's. ``floating``: the
        gripper rides the gantry (the scenario's carrier), whose stiff servos do not lag
        behind the descent as the arm does; the pile is at rest already and nothing is
        released after the count, so the waits are short and the gripper does not go home."""
        settings = pick_settings(scenario, max_picks=1)
        if floating:
            settings = replace(settings, settle_time=0.05, close_delay=0.05,
                               release_time=_POLL)
        return cls(scenario, methods, part, settings, return_home=not floating,
                   lock_until_descent=True, fast=fast,
                   sim_limit=FLOATING_SIM_LIMIT if floating else SIM_TIME_PER_PICK)

    @classmethod
    def clearing(cls, scenario: Scenario, methods: Sequence[Method], part: str,
                 open_loop: bool = False) -> Episode:
        """A whole bin per run: closed loop (at most one delivery per part in the pile, the
        lift as the scenario's ``pick`` says) or open loop (two grasps per part)."""
        count = scenario.pile.total_count
        settings = pick_settings(scenario, max_picks=2 * count) if open_loop \
            else closed_loop_settings(scenario, max_picks=count)
        return cls(scenario, methods, part, settings)

    def settle(self, seed: int) -> SettledPile:
        """Drop and settle the pile made with ``seed``."""
        return self.settler.settle(seed)

    def pick(self, state: np.ndarray, run: MethodRun,
             physics: PickPhysics | None = None) -> PhysicalPick:
        """Restore the settled plant ``state`` and make one pick as ``run`` says, under the
        model's physics or, given ``physics``, under that draw (the restored context brings
        the model's back for the next pick)."""
        episode = self.episode
        station = episode.pick.station
        depth = []
        locked = station.pile_bodies if self.lock_until_descent else []
        if physics is not None:
            run = run._replace(offset=physics.offset)

        def prepare(context: Context) -> None:
            if physics is not None:
                self._contacts.apply(context, physics.friction, physics.pad_stiffness)
            depth.append(station.GetOutputPort("camera.depth_image").Eval(
                station.GetMyContextFromRoot(context)))
            for body in locked:
                body.Lock(station.mutable_plant_context(context))

        def step(mode: Mode) -> float:
            nonlocal locked
            if locked and mode not in _UNTOUCHED:
                for body in locked:
                    body.Unlock(station.mutable_plant_context(episode.context))
                locked = []
                if self._reach is not None:
                    self._freeze_out_of_reach()
            return self.update_period if locked else _POLL

        self.start(state, run, prepare)
        try:
            result = episode.run(self.sim_limit, step=step,
                                 pause_at=Mode.LIFT if self.fast else None)
            if result.end is RunEnd.PAUSED:
                if (empty := self._empty_close()) is not None:
                    return PhysicalPick(empty, result.time, self._image(depth))
                result = episode.run(self.sim_limit - result.time, step=step)
        finally:
            self._freeze.thaw(episode.context)
        record = result.records[0] if result.records else None
        return PhysicalPick(record, result.time, self._image(depth))

    def start(self, state: np.ndarray, run: MethodRun,
              prepare: Callable[[Context], None] | None = None) -> None:
        """Restore the settled plant ``state`` into the diagram's initial state, selecting as
        ``run`` says; ``prepare`` may set more before the diagram initializes."""
        diagram = self.episode.pick.diagram

        def select(context: Context) -> None:
            diagram.GetInputPort("method").FixValue(context, run)
            if prepare is not None:
                prepare(context)

        self.episode.start(state, select)

    def run(self, time_limit: float, step: Callable[[Mode], float] | None = None,
            **options) -> PickRun:
        """Run the diagram from where it is (after :meth:`start` in simulation) until its
        planner is done, the safety stops it or ``time_limit`` seconds have passed
        (``step`` and ``options``: as :func:`~.run.run_picks` takes them). With the
        scenario's ``simulation.freeze_beyond_radii``, each grasp's descent freezes the parts
        out of its reach (those frozen for the grasp before wake first); they stay frozen
        while the robot is away from the pile, every part at rest joins them once it is home,
        and a shake, a put-back or a stir wakes them; before the first grasp the whole settled
        pile is frozen (:func:`freeze_change`)."""
        if self._reach is None:
            return run_picks(self.clock, self.pick_diagram, time_limit, step=step, **options)
        frozen_for: set[int] = set()  # the grasps (their records' indices) frozen for
        rested: set[int] = set()  # the grasp counts after which the resting pile was frozen

        def freezing(mode: Mode) -> float:
            context = self.episode.context
            current = self.pick_diagram.diagram.GetOutputPort("current_pick").Eval(context)
            change = freeze_change(mode, None if current is None else current.index,
                                   frozen_for, bool(self._freeze.frozen),
                                   len(frozen_for) in rested)
            if change is not None:
                self._freeze.thaw(context)
            if change == "grasp":
                frozen_for.add(current.index)
                self._freeze_out_of_reach()
            elif change is not None and change != "wake":  # "pile", "rest"
                resting = (self._freeze.speeds(context) < self.scenario.pile.settle_speed) \
                    & inside_bin(self._bin, self._freeze.centres(context))
                self._freeze.freeze(context, np.flatnonzero(resting).tolist())
                rested.add(len(frozen_for))
            return _POLL if step is None else step(mode)

        try:
            return run_picks(self.clock, self.pick_diagram, time_limit, step=freezing,
                             **options)
        finally:
            self._freeze.thaw(self.episode.context)

    def _freeze_out_of_reach(self) -> None:
        """Freeze the parts too far from the grasp being made to take part in its lift."""
        context = self.episode.context
        record = self.episode.pick.diagram.GetOutputPort("current_pick").Eval(context)
        pose = getattr(record.candidate, "pose", None)
        if pose is not None:
            far = parts_beyond(self._freeze.centres(context), self._bin, pose[:2, 3],
                               self._reach)
            self._freeze.freeze(context, far)

    def _empty_close(self) -> PickRecord | None:
        """At the end of the close, the record of a grasp whose fingers closed on nothing,
        judged as the top of the lift would judge it; ``None`` if they hold something."""
        context = self.episode.context
        station = self.episode.pick.station
        width = float(station.GetOutputPort("gripper.state_measured").Eval(
            station.GetMyContextFromRoot(context))[0])
        if classify_lift(width, None, self.empty_width) is not Outcome.NONE:
            return None
        record = self.episode.pick.diagram.GetOutputPort("current_pick").Eval(context)
        return replace(record, outcome=Outcome.NONE, width=width,
                       timing=replace(record.timing, execution_s=context.get_time()
                                      - record.timing.started_at))

    @staticmethod
    def _image(depth: list) -> np.ndarray:
        return np.asarray(depth[0].data)[:, :, 0].copy()


def picking(scenario: Scenario) -> Scenario:
    """``scenario`` as the pick diagram's station simulates it: at its
    ``simulation.pick_time_step`` (the pile is settled at ``plant_config.time_step``)."""
    time_step = scenario.simulation.pick_time_step
    if time_step is None:
        return scenario
    plant_config = copy.copy(scenario.plant_config)
    plant_config.time_step = time_step
    return replace(scenario, plant_config=plant_config)


def freeze_change(mode: Mode, grasp: int | None, frozen_for: set[int], frozen: bool,
                  rested: bool) -> str | None:
    """What a run's freeze does as the planner is seen in ``mode`` with ``grasp`` (its
    record's index) in progress: ``"pile"``, freeze every resting part in the bin (before the
    first grasp: the settled pile is untouched until a descent); ``"grasp"``, wake the parts
    and freeze those out of this grasp's reach (at its descent, once); ``"rest"``, freeze
    every part in the bin that has come to rest (once the robot has gone home after a grasp,
    ``rested`` telling whether that was done since the last descent); ``"wake"``, wake them
    (a shake, a put-back or a stir moves things through the pile); ``None``, leave it."""
    if mode in _WAKING:
        return "wake" if frozen else None
    if mode is Mode.DESCEND and grasp is not None and grasp not in frozen_for:
        return "grasp"
    if not frozen_for and not frozen and mode in _UNTOUCHED:
        return "pile"
    if frozen_for and not rested and mode is Mode.HOME:
        return "rest"
    return None
