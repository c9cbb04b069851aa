"""The typed scenario: everything that makes one station, loaded from YAML under ``diagrams/``.

Follows Drake's ``examples/hardware_sim``: a dataclass schema read with ``yaml_load_typed``, model
directives for the robot, Drake's own ``MultibodyPlantConfig`` and ``CameraConfig``. On top of
Drake's loader we name the offending field in every error, because "could not convert string to
float" alone does not tell a user which of fifty lines to fix.
"""

# No `from __future__ import annotations`: Drake's YAML loader needs real field types.

import typing
from dataclasses import dataclass, field, replace
from pathlib import Path

from pydrake.common.yaml import yaml_load_typed
from pydrake.lcm import DrakeLcmParams
from pydrake.multibody.parsing import (
    FlattenModelDirectives,
    ModelDirective,
    ModelDirectives,
    PackageMap,
)
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.sensors import CameraConfig

from tangle_drake.common.errors import SEED_LIMIT, TangleDrakeError
from tangle_drake.common.paths import register_packages
from tangle_drake.scenario.drivers import (
    DriverConfig,
    ForceTorqueSensor,
    NextageDriver,
    ParallelJawDriver,
    camera_channel,
)
from tangle_drake.scenario.hardware import HardwareConfig, check_lcm_url, default_lcm_buses
from tangle_drake.scenario.pick import PickConfig
from tangle_drake.scenario.yaml_io import Tagged, find_bad_field, read_mapping


def _default_plant_config() -> MultibodyPlantConfig:
    # 2 ms or less: at 5 ms thin wire parts tunnel through the bin's floor (method.md).
    # Hydroelastic with fallback: the gripper's compliant pads hold light wire parts, while
    # part-on-part contact stays point contact (parts are rigid hydroelastic; see parts/sdf.py).
    return MultibodyPlantConfig(time_step=0.002, discrete_contact_approximation="sap",
                                contact_model="hydroelastic_with_fallback")


def _default_camera() -> CameraConfig:
    return CameraConfig(name="camera", width=640, height=480, rgb=True, depth=True,
                        label=True, z_near=0.05, z_far=2.0, clipping_near=0.01,
                        clipping_far=3.0, renderer_class="RenderEngineVtk")


@dataclass
class BinConfig:
    """A rectangular open box on a fixed stand; sizes are inner sizes."""

    center: list[float] = field(default_factory=lambda: [0.34, 0.22])
    """World (x, y) of the inner floor's centre, m. The default is where the left arm reaches
    every point of the bin with the gripper pointing down (``tools/nextage_reach.py``)."""
    floor_height: float = 0.93
    """World z of the inner floor's top surface, m."""
    inner_size: list[float] = field(default_factory=lambda: [0.20, 0.28])
    """Inner extent along world (x, y), m."""
    wall_height: float = 0.10
    """Height of the walls above the inner floor, m."""
    wall_thickness: float = 0.01
    floor_thickness: float = 0.01

    def validate(self, where: str) -> None:
        _require(len(self.center) == 2, f"{where}.center", "must be [x, y]")
        _require(len(self.inner_size) == 2, f"{where}.inner_size", "must be [size_x, size_y]")
        _require(all(s > 0 for s in self.inner_size), f"{where}.inner_size", "must be positive")
        for name in ("wall_height", "wall_thickness", "floor_thickness"):
            _require(getattr(self, name) > 0, f"{where}.{name}", "must be positive")


@dataclass
class PartCount:
    """``count`` copies of one part: a built-in name or a mesh file with its unit scale."""

    part: str = "u_hook"
    count: int = 15
    mesh_scale: float = 1.0


@dataclass
class PileConfig:
    """How the random pile is made: which parts, and when it counts as settled."""

    parts: list[PartCount] = field(default_factory=lambda: [PartCount()])
    seed: int = 0
    settle_speed: float = 0.02
    """A part is at rest when its translational speed is below this, m/s."""
    settle_time_max: float = 4.0
    """Simulated seconds after which the pile is taken as it is, s."""
    max_penetration: float = 0.003
    """Deeper interpenetration than this marks a part as badly placed, m."""
    max_redraws: int = 3
    """How many times parts that ended outside the bin are dropped again."""
    drop_inside_walls: bool = False
    """Parts dropped from higher than the rim (a full, deep bin) keep their bounding radius
    inside the walls, so none lands hanging on the rim; lower ones fall anywhere over the
    floor, as always."""
    part_counts: dict[str, int] = field(default_factory=dict)
    """Part -> how many make the pile where that part alone replaces the pile's parts (the
    benchmark's ``--parts``, the demo's ``--part``, ``collect`` and ``teach``): a deep bin
    holds fewer long parts than short ones. A part not named keeps the pile's total count."""

    def validate(self, where: str) -> None:
        for part, count in self.part_counts.items():
            _require(count >= 1, f"{where}.part_counts[{part}]", "must be >= 1")
        for i, entry in enumerate(self.parts):
            _require(entry.count >= 0, f"{where}.parts[{i}].count", "must be >= 0")
            _require(entry.mesh_scale > 0, f"{where}.parts[{i}].mesh_scale", "must be positive")
            _require(bool(entry.part), f"{where}.parts[{i}].part", "must name a part")
        _require(self.settle_speed > 0, f"{where}.settle_speed", "must be positive")
        _require(self.settle_time_max > 0, f"{where}.settle_time_max", "must be positive")
        _require(self.max_redraws >= 0, f"{where}.max_redraws", "must be >= 0")
        _require(0 <= self.seed < SEED_LIMIT, f"{where}.seed",
                 "must be a non-negative 63-bit integer")

    @property
    def total_count(self) -> int:
        return sum(entry.count for entry in self.parts)

    def alone(self, part: str, mesh_scale: float = 1.0, count: int | None = None) -> "PileConfig":
        """This pile made of ``part`` alone: ``count`` of it, else its ``part_counts`` entry,
        else as many as the pile held."""
        count = count or self.part_counts.get(part, self.total_count)
        return replace(self, parts=[PartCount(part, count, mesh_scale)])


PICK_TIME_STEP_MAX = 0.003
"""The largest time step a pick may run at, s. Even 3 ms changes outcomes: E-shapes slip out of
the pads where at 2 ms they come up (``docs/results/physics/step3ms_freeze2``); at 4 ms
several parts come up as one or none more often. Faster, not the same picks."""


@dataclass
class SimulationConfig:
    """What the simulated pick may skip without changing what comes up (simulation only: the
    hardware station ignores it). The pile is always dropped and settled at
    ``plant_config.time_step``."""

    pick_time_step: float | None = None
    """The plant's time step while picking, s; ``None``: ``plant_config.time_step``."""
    freeze_beyond_radii: float | None = None
    """At each grasp's descent, the parts whose centres lie farther (horizontally) than this
    many of the pile's largest bounding radius from the grasp are frozen: locked, their
    contacts with each other and the bin out of the queries. A run keeps the settled pile
    frozen until its first descent and what no grasp reaches frozen while the robot is away,
    and freezes every part at rest once it is home; a shake, a put-back or a stir wakes them
    all. ``None``: nothing frozen (a physical-pick
    sample keeps its own 3)."""

    def validate(self, where: str) -> None:
        _require(self.pick_time_step is None or 0 < self.pick_time_step <= PICK_TIME_STEP_MAX,
                 f"{where}.pick_time_step", f"must be in (0, {PICK_TIME_STEP_MAX}] s")
        _require(self.freeze_beyond_radii is None or self.freeze_beyond_radii >= 1,
                 f"{where}.freeze_beyond_radii",
                 "must be at least 1: the grasped part reaches one radius from the grasp")


@dataclass
class Scenario:
    """One station: plant settings, models and their drivers, bin, pile, top camera, view
    cameras, LCM buses."""

    plant_config: MultibodyPlantConfig = field(default_factory=_default_plant_config)
    directives: list[ModelDirective] = field(default_factory=list)
    """The gripper and what carries it (e.g. ``package://nextage/nextage_with_gripper.dmd.yaml``
    or ``package://gantry/floating_gripper.dmd.yaml``); empty for a robot-less station such
    as the tangle-data simulator's."""
    model_drivers: dict[str, DriverConfig] = field(default_factory=dict)
    """Model instance name -> its driver (``!NextageDriver``, ``!GantryDriver``,
    ``!ParallelJawDriver``; :mod:`tangle_drake.scenario.drivers`). Every model with actuators
    needs one; a picking station has one carrier and the gripper ``gripper``."""
    force_torque_sensors: dict[str, ForceTorqueSensor] = field(default_factory=dict)
    """Sensor name -> a 6-axis force/torque sensor in a weld (``wrist``: between the carrier
    and the gripper), port ``{name}.force_torque``."""
    initial_positions: dict[str, float] = field(default_factory=dict)
    """Joint name -> initial position (rad or m); the robot's other joints start at
    ``robot.HOME``."""
    bin: BinConfig = field(default_factory=BinConfig)
    tray: BinConfig | None = None
    """The output tray beside the bin that picked parts are released into (a box like the
    bin); ``None``: parts are released beside the bin, onto the floor."""
    pile: PileConfig = field(default_factory=PileConfig)
    random_seed: int = 0
    """Seeds the run's draws other than the pile's (``pile.seed``): the ``random`` rule's
    choices. The same scenario gives the same run."""
    pick: PickConfig = field(default_factory=PickConfig)
    simulation: SimulationConfig = field(default_factory=SimulationConfig)
    camera: CameraConfig = field(default_factory=_default_camera)
    camera_height: float | None = 0.5
    """If set, the camera looks straight down from this height above the bin's floor centre
    and ``camera.X_PB`` is ignored; if null, ``camera.X_PB`` places it."""
    view_cameras: list[CameraConfig] = field(default_factory=list)
    """Extra colour cameras for people to look through (e.g. an overview of the robot); each
    gives a port ``{name}.rgb_image`` and ``tangle-drake scene`` writes ``{name}.png``."""
    lcm_buses: dict[str, DrakeLcmParams] = field(default_factory=default_lcm_buses)
    """LCM buses by name, as in Drake's ``hardware_sim``; the default bus is in-process only
    (``memq://``). A real robot's network URL goes here (``docs/hardware.md``)."""
    hardware: HardwareConfig = field(default_factory=HardwareConfig)
    """Rates and timeouts of the LCM link to the robot's drivers
    (``build_station(hardware=True)``)."""

    def validate(self) -> None:
        time_step = self.plant_config.time_step
        _require(0 < time_step <= 0.002, "plant_config.time_step",
                 "must be in (0, 0.002] s: larger steps let thin parts tunnel through the bin")
        _require(self.plant_config.discrete_contact_approximation in ("sap", "lagged", "similar"),
                 "plant_config.discrete_contact_approximation",
                 "must be sap, lagged or similar (TAMSI diverges on piles)")
        self.bin.validate("bin")
        if self.tray is not None:
            self.tray.validate("tray")
            _require(not _footprints_overlap(self.bin, self.tray), "tray",
                     "must stand beside the bin, not over it")
        self.pile.validate("pile")
        self.pick.validate("pick")
        self.simulation.validate("simulation")
        _require(0 <= self.random_seed < SEED_LIMIT, "random_seed",
                 "must be a non-negative 63-bit integer")
        _require(self.camera.depth, "camera.depth", "must be true: graspability needs depth")
        _require(self.camera_height is None or self.camera_height > self.bin.wall_height,
                 "camera_height", "must be above the bin's walls")
        for where, camera in [("camera", self.camera)] + [
                (f"view_cameras[{i}]", c) for i, c in enumerate(self.view_cameras)]:
            try:
                camera.MakeCameras()
            except RuntimeError as error:
                raise TangleDrakeError(f"scenario field '{where}': {error}") from error
        names = [c.name for c in self.view_cameras]
        _require(len(set(names)) == len(names) and self.camera.name not in names,
                 "view_cameras", "need names unique among all cameras")
        self._validate_models()
        self.hardware.validate("hardware")
        for name, bus in self.lcm_buses.items():
            check_lcm_url(bus.lcm_url, f"lcm_buses.{name}.lcm_url")
        self._validate_links()

    def _validate_models(self) -> None:
        """Every model the directives add, their nested files included, has its own name."""
        package_map = PackageMap()
        register_packages(package_map)
        try:
            flat = FlattenModelDirectives(ModelDirectives(directives=self.directives),
                                          package_map)
        except RuntimeError as error:
            raise TangleDrakeError(f"scenario field 'directives': {error}") from error
        names = [d.add_model.name for d in flat.directives if d.add_model is not None]
        repeated = sorted({name for name in names if names.count(name) > 1})
        _require(not repeated, "directives",
                 f"add the model {', '.join(map(repr, repeated))} more than once: each "
                 "add_model needs its own name")

    def _validate_links(self) -> None:
        """Every driver's and the camera's bus exists; every channel is named, and only once."""
        links = [(f"model_drivers.{name}", config.lcm_bus,
                  [config.command_channel, config.status_channel])
                 for name, config in self.model_drivers.items()]
        links += [(f"force_torque_sensors.{name}", sensor.lcm_bus, [sensor.channel])
                  for name, sensor in self.force_torque_sensors.items()]
        links.append(("camera", self.camera.lcm_bus, [camera_channel(self.camera)]))
        channels: list[str] = []
        for where, bus, names in links:
            buses = ", ".join(sorted(self.lcm_buses)) or "none"
            _require(bus in self.lcm_buses, f"{where}.lcm_bus",
                     f"names no bus in 'lcm_buses' ({buses})")
            _require(all(names), where, "needs non-empty channel names")
            channels += names
        repeated = sorted({c for c in channels if channels.count(c) > 1})
        _require(not repeated, "model_drivers", f"use channel {', '.join(repeated)} twice")
        for name, sensor in self.force_torque_sensors.items():
            where = f"force_torque_sensors.{name}"
            _require(sensor.period > 0, f"{where}.period", "must be positive")
            for value in ("force_noise", "torque_noise", "force_drift", "torque_drift",
                          "force_resolution", "torque_resolution", "cutoff_frequency"):
                _require(getattr(sensor, value) >= 0, f"{where}.{value}", "must be >= 0")
        for name, config in self.model_drivers.items():
            if isinstance(config, ParallelJawDriver):
                _require(config.force_limit > 0, f"model_drivers.{name}.force_limit",
                         "must be positive")
            if isinstance(config, NextageDriver):
                for limit in ("planning_velocity_limit", "planning_acceleration_limit",
                              "planning_slow_speed"):
                    _require(0 < getattr(config, limit) < float("inf"),
                             f"model_drivers.{name}.{limit}", "must be positive and finite")


def _footprints_overlap(a: BinConfig, b: BinConfig) -> bool:
    """Whether two boxes' outer footprints overlap (walls included)."""
    for axis in range(2):
        half_a = a.inner_size[axis] / 2 + a.wall_thickness
        half_b = b.inner_size[axis] / 2 + b.wall_thickness
        if abs(a.center[axis] - b.center[axis]) >= half_a + half_b:
            return False
    return True


def _require(condition: bool, field_path: str, message: str) -> None:
    if not condition:
        raise TangleDrakeError(f"scenario field '{field_path}' {message}")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML; errors name the file and the offending field."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise TangleDrakeError(f"cannot read scenario file {path}: {error.strerror}") from error
    return parse_scenario(text, source=str(path))


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """Parse scenario YAML text (see :func:`load_scenario`)."""
    raw = read_mapping(text, source)
    _check_driver_tags(raw.get("model_drivers"), source)
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text, defaults=Scenario())
    except (RuntimeError, ValueError, TypeError) as error:
        where = find_bad_field(Scenario, raw, "")
        raise TangleDrakeError(f"{source}: scenario field '{where}': {error}") from error
    try:
        scenario.validate()
    except TangleDrakeError as error:
        raise TangleDrakeError(f"{source}: {error}") from error
    return scenario


def _check_driver_tags(drivers: object, source: str) -> None:
    """Drake's loader takes an untagged driver as the first kind; make the user say which."""
    if not isinstance(drivers, dict):
        return
    for name, value in drivers.items():
        if not isinstance(value, Tagged):
            kinds = ", ".join(f"!{kind.__name__}" for kind in typing.get_args(DriverConfig))
            raise TangleDrakeError(f"{source}: scenario field 'model_drivers.{name}' needs a "
                                   f"driver tag: one of {kinds}")
