"""The pick diagram: station, graspability, grasp selection, pick planner and (in simulation)
the lift monitor, wired by port name so the same builder serves the hardware station.

    camera.depth_image -> GraspabilitySystem -> candidates ----------------> PickPlanner
                       \\-> [TangleCnnSystem ->] GraspSelector -> scored_candidates,
                                                        selected_grasp -> PickPlanner
    nextage.state_measured, gripper.state_measured ------------------------> PickPlanner
    PickPlanner -> nextage.position, gripper.position -> station
    sim.body_poses -> LiftMonitor, sim.contact_results -> LoadPathMonitor,
        PickPlanner's records -> PickTruth -> truth   (simulation only: beside the planner,
                                                        never into it)
    safety.fault ----------------------------------------------> PickPlanner   (hardware only)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from pydrake.geometry import Meshcat
from pydrake.systems.framework import Diagram, DiagramBuilder, OutputPort

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.drivers.parallel_jaw import empty_grasp_width
from tangle_drake.graspability import FINGER_GRIP_SPAN_M, GraspabilityParams, bin_roi
from tangle_drake.graspability.system import GraspabilitySystem
from tangle_drake.parts import load_part
from tangle_drake.parts.catalog import BUILTIN_PARTS, builtin_spec
from tangle_drake.perception.camera import CameraModel
from tangle_drake.pick.bin_contents import BinContentsSystem
from tangle_drake.pick.bin_time import BinTime
from tangle_drake.pick.load_path import LoadPathMonitor
from tangle_drake.pick.outcome import LiftMonitor, TrayMonitor
from tangle_drake.pick.payload import (
    PayloadEstimator,
    PayloadSettings,
    best_count_std,
    surest_count_std,
)
from tangle_drake.pick.planner import PickPlanner, PickSettings
from tangle_drake.pick.recovery import RecoverySettings
from tangle_drake.pick.truth import PickTruth
from tangle_drake.planning.motion import Motion
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.scenario import BinConfig, PileConfig, Scenario
from tangle_drake.scenario.pick import tuned
from tangle_drake.station import SimulatedStation, build_station, camera_model
from tangle_drake.station.bin_model import inner_corners

WRIST = "wrist"
"""The force/torque sensor the closed loop weighs with (``force_torque_sensors.wrist``)."""

SelectionWiring = Callable[[DiagramBuilder, OutputPort, OutputPort],
                           tuple[OutputPort, OutputPort]]
"""Adds a selection of its own to the builder: given the depth image and the graspability
candidates, returns its ``scored_candidates`` and ``selected_grasp`` ports (as
``TangleCnnSystem`` has), which the planner then follows."""


@dataclass
class PickDiagram:
    """The built diagram and the parts of it a driver needs."""

    diagram: Diagram
    station: Diagram
    planner: PickPlanner
    monitor: LiftMonitor | None
    """``None`` on a station that is not simulated."""
    tray: TrayMonitor | None = None
    """Simulation only, with a tray in the scenario: what lies in it."""
    payload: PayloadEstimator | None = None
    """Closed loop: the estimator that weighs each lift."""
    truth: PickTruth | None = None
    """Simulation only: what each pick truly brought up (the diagram's ``truth`` output)."""


def palm_margin_px(camera: CameraModel, bin_config: BinConfig,
                   spec: GripperSpec = DEFAULT_GRIPPER) -> int:
    """Pixels to keep the fingers' footprint off the bin's edge so the wider palm fits too.

    Graspability plans for the fingers; the palm, wider on every side, goes below the rim
    on deep grasps, and near a wall it would hit it. Measured at the bin floor's depth, where
    pixels are smallest in metres (so the margin is never too small).
    """
    palm_x, palm_y, _ = spec.palm_size
    extra = max((palm_y - spec.outer_width_open) / 2, (palm_x - spec.finger_width) / 2, 0.0)
    floor_depth = float(camera.X_WC[2, 3]) - bin_config.floor_height
    metres_per_px = floor_depth / camera.intrinsics.fx
    return math.ceil(extra / metres_per_px)


def thinnest_wire(pile: PileConfig) -> float | None:
    """Diameter of the thinnest built-in wire part in the pile, m; ``None`` for mesh parts
    only, whose wire is unknown."""
    wires = [builtin_spec(e.part).wire_diameter * e.mesh_scale for e in pile.parts
             if e.part in BUILTIN_PARTS]
    return min(wires) if wires else None


def pick_settings(scenario: Scenario, **overrides) -> PickSettings:
    """The planner's settings for the scenario's pile: the empty-grasp width of its thinnest
    wire (:func:`~tangle_drake.drivers.parallel_jaw.empty_grasp_width`), the scenario's
    ``pick.planner``, then ``overrides``."""
    settings = tuned(PickSettings(empty_width=empty_grasp_width(thinnest_wire(scenario.pile))),
                     scenario.pick.planner, "pick.planner")
    return replace(settings, **overrides)


def closed_loop_settings(scenario: Scenario, **overrides) -> PickSettings:
    """:func:`pick_settings` for the closed loop: weigh every lift (the scenario needs a
    ``wrist`` force/torque sensor and a tray), the lift high enough for a chain of the
    scenario's ``pick.hanging_parts`` (0: the approach's fixed lift) of the pile's longest
    part to be weighed clear of the pile."""
    missing = [what for what, ok in (("a 'wrist' force/torque sensor",
                                      WRIST in scenario.force_torque_sensors),
                                     ("a 'tray'", scenario.tray is not None)) if not ok]
    if missing:
        raise TangleDrakeError(f"closed-loop picking needs {' and '.join(missing)} in the "
                               "scenario (as pick_demo.yaml has); without, pick open loop "
                               "(--open-loop, or 'pick: {closed_loop: false}' in it)")
    recovery = tuned(RecoverySettings(
        hanging_length=scenario.pick.hanging_parts * part_span(scenario.pile)),
        scenario.pick.recovery, "pick.recovery")
    return pick_settings(scenario, **{"recovery": recovery, **overrides})


TARE_TO_WEIGH = 4.0
"""About how long a pick takes from the tare at the pre-grasp to the weighing at the top of
the lift, s (descent, close, lift and the waits)."""


def payload_settings(scenario: Scenario) -> PayloadSettings:
    """How the closed loop's estimator weighs the scenario's pile with its wrist sensor."""
    sensor = scenario.force_torque_sensors[WRIST]
    return tuned(PayloadSettings(part_mass=part_mass(scenario.pile), period=sensor.period,
                                 sensor_noise=max(sensor.force_noise, sensor.force_resolution)),
                 scenario.pick.payload, "pick.payload")


def weighing_warning(scenario: Scenario) -> str | None:
    """A warning, before any long work, when the scenario's wrist sensor cannot weigh its
    parts surely enough for the closed loop (``None`` when it can, or has no sensor). The
    estimator's own confidence counts the noise it sees, not the bias's drift since the
    tare, which this does."""
    if WRIST not in scenario.force_torque_sensors:
        return None
    sensor = scenario.force_torque_sensors[WRIST]
    settings = payload_settings(scenario)
    std = best_count_std(settings, sensor.force_drift, TARE_TO_WEIGH)
    surest = surest_count_std(settings)
    if std <= surest:
        return None
    return (f"warning: the wrist sensor ({settings.sensor_noise:g} N noise, "
            f"{sensor.force_drift:g} N/√s drift) weighs one part of {settings.part_mass * 1e3:.1f}"
            f" g to ±{std:.2f} parts at best (its noise over {settings.max_window:g} s, its "
            f"drift over the ~{TARE_TO_WEIGH:g} s from the tare to the weighing), more than the "
            f"±{surest:.2f} at which one part is told from two at "
            f"{settings.min_confidence:.0%}: expect lifts put back, bins given up on, or two "
            "parts taken for one; use a finer sensor, or pick open loop")


def part_mass(pile: PileConfig) -> float:
    """One part's mass for weighing, kg: the lightest of the pile's parts (a pile of one
    part type weighs in whole parts)."""
    return min(load_part(e.part, mesh_scale=e.mesh_scale).mass for e in pile.parts)


def part_span(pile: PileConfig) -> float:
    """The longest a part of the pile can hang below the point it is held by, m: the
    diameter of the sphere about its centre of mass that encloses it."""
    return max(2 * load_part(e.part, mesh_scale=e.mesh_scale).bounding_radius
               for e in pile.parts)


def default_graspability_params(scenario: Scenario) -> GraspabilityParams:
    """Graspability settings for picking with the real fingers, then the scenario's
    ``pick.graspability``.

    The insertion depth is one depth level less than the thinnest wire, so a wire lying alone
    on the bin's floor still has its top above the fingertips' level plus the insertion
    (the planner presses the grasp deeper anyway, see ``ApproachSettings.press_depth``).
    The grip test is on (:data:`~tangle_drake.graspability.params.FINGER_GRIP_SPAN_M`): real
    fingers push a wire that runs between them out sideways.
    The candidates keep the palm's overhang off the bin's walls (:func:`palm_margin_px`), and
    there are twice the index's default number of them, as the arm cannot reach every one
    (deep in the bin, near the wall on the robot's side, the wrist meets the wall).
    """
    defaults = GraspabilityParams()
    wire = thinnest_wire(scenario.pile)
    insertion = defaults.insertion_depth_m if wire is None else max(
        defaults.insertion_depth_m, wire - defaults.level_step_m)
    derived = replace(defaults, insertion_depth_m=insertion, top_k=2 * defaults.top_k,
                      max_grip_span_m=FINGER_GRIP_SPAN_M,
                      roi_margin_px=palm_margin_px(camera_model(scenario), scenario.bin))
    return tuned(derived, scenario.pick.graspability, "pick.graspability")


def build_pick_diagram(scenario: Scenario, motion: Motion, selection: SelectionWiring, *,
                       station: Diagram | None = None, settings: PickSettings | None = None,
                       meshcat: Meshcat | None = None) -> PickDiagram:
    """Wire the pick diagram around ``station`` (built from ``scenario`` if not given).

    ``motion`` moves the arm (``ArmMotion`` for the Nextage); ``selection`` wires the grasp
    selection between perception and the planner
    (:func:`~tangle_drake.selection.methods.selection_wiring`: one method fixed, or the
    benchmark's ``method`` input); graspability is :func:`default_graspability_params`;
    ``meshcat`` is passed to a station built here.
    """
    station = station or build_station(scenario, meshcat)
    needed = [(motion.measured_port, True), ("gripper.state_measured", True),
              ("camera.depth_image", True), (motion.command_port, False),
              ("gripper.position", False)]
    for port, output in needed:
        if not (station.HasOutputPort(port) if output else station.HasInputPort(port)):
            raise TangleDrakeError(f"the station has no {port!r} port: picking needs the "
                                   "robot, its gripper and the top camera (a scenario whose "
                                   "directives add them, like pick_demo.yaml)")
    camera = camera_model(scenario)
    roi = bin_roi(camera, inner_corners(scenario.bin))
    params = default_graspability_params(scenario)

    builder = DiagramBuilder()
    builder.AddSystem(station)
    graspability = builder.AddNamedSystem(
        "graspability", GraspabilitySystem(camera, DEFAULT_GRIPPER, params, roi))
    planner_settings = settings or PickSettings()
    planner = builder.AddNamedSystem("pick_planner", PickPlanner(motion, planner_settings,
                                                                 camera.intrinsics))
    depth = station.GetOutputPort("camera.depth_image")
    builder.Connect(depth, graspability.GetInputPort("depth_image"))
    if planner_settings.record_crop is not None or planner_settings.record_view:
        builder.Connect(depth, planner.GetInputPort("depth_image"))
    builder.Connect(graspability.GetOutputPort("candidates"), planner.GetInputPort("candidates"))
    scored, selected = selection(builder, depth, graspability.GetOutputPort("candidates"))
    builder.Connect(scored, planner.GetInputPort("scored_candidates"))
    builder.Connect(selected, planner.GetInputPort("selected_grasp"))

    for port in (motion.measured_port, "gripper.state_measured"):
        builder.Connect(station.GetOutputPort(port), planner.GetInputPort(port))
    if station.HasOutputPort("camera.image_time"):  # a look waits for an image taken after
        builder.Connect(station.GetOutputPort("camera.image_time"),  # the arm stopped
                        planner.GetInputPort("camera.image_time"))
    for port in (motion.command_port, "gripper.position"):
        builder.Connect(planner.GetOutputPort(port), station.GetInputPort(port))

    if station.HasOutputPort("safety.fault"):  # the hardware station's
        builder.Connect(station.GetOutputPort("safety.fault"),
                        planner.GetInputPort("safety.fault"))
    payload = None
    if planner_settings.recovery is not None:
        payload = _add_payload(builder, scenario, station, planner, motion)
        contents = builder.AddNamedSystem("bin_contents", BinContentsSystem(camera,
                                                                            scenario.bin))
        builder.Connect(depth, contents.GetInputPort("depth_image"))
        builder.Connect(contents.GetOutputPort("bin_contents"),
                        planner.GetInputPort("bin_contents"))
    monitor = tray = truth = None
    if isinstance(station, SimulatedStation):
        poses = station.GetOutputPort("sim.body_poses")
        monitor = builder.AddNamedSystem("lift_monitor (sim only)",
                                         LiftMonitor(station.plant, scenario.bin))
        builder.Connect(poses, monitor.GetInputPort("body_poses"))
        load_path = builder.AddNamedSystem("load_path_monitor (sim only)",
                                           LoadPathMonitor(station.plant))
        builder.Connect(station.GetOutputPort("sim.contact_results"),
                        load_path.GetInputPort("contact_results"))
        truth = builder.AddNamedSystem("pick_truth (sim only)",
                                       PickTruth(planner_settings.update_period))
        for source, port in ((monitor, "lifted_count"), (load_path, "held_count"),
                             (planner, "current_pick"), (planner, "picks")):
            builder.Connect(source.GetOutputPort(port), truth.GetInputPort(port))
        builder.ExportOutput(truth.GetOutputPort("truth"), "truth")
        if scenario.tray is not None:
            tray = builder.AddNamedSystem("tray_monitor (sim only)",
                                          TrayMonitor(station.plant, scenario.tray))
            builder.Connect(poses, tray.GetInputPort("body_poses"))
    bin_time = builder.AddNamedSystem("bin_time", BinTime(motion, scenario.bin,
                                                          planner_settings.update_period))
    builder.Connect(station.GetOutputPort(motion.measured_port),
                    bin_time.GetInputPort(motion.measured_port))
    for port in ("mode", "current_pick"):
        builder.Connect(planner.GetOutputPort(port), bin_time.GetInputPort(port))
    builder.ExportOutput(bin_time.GetOutputPort("bin_times"), "bin_times")
    builder.ExportOutput(planner.GetOutputPort("mode"), "mode")
    builder.ExportOutput(planner.GetOutputPort("picks"), "picks")
    builder.ExportOutput(planner.GetOutputPort("current_pick"), "current_pick")
    diagram = builder.Build()
    diagram.set_name("pick_demo")
    return PickDiagram(diagram, station, planner, monitor, tray, payload, truth)


def _add_payload(builder: DiagramBuilder, scenario: Scenario, station: Diagram,
                 planner: PickPlanner, motion: Motion) -> PayloadEstimator:
    """The estimator between the wrist sensor, the carrier's state and the planner."""
    estimator = builder.AddNamedSystem("payload", PayloadEstimator(payload_settings(scenario),
                                                                   motion.measured_size))
    wrench = station.GetOutputPort(f"{WRIST}.force_torque")
    builder.Connect(wrench, estimator.GetInputPort("force_torque"))
    builder.Connect(wrench, planner.GetInputPort("wrist.force_torque"))
    builder.Connect(station.GetOutputPort(motion.measured_port),
                    estimator.GetInputPort("carrier_state"))
    builder.Connect(planner.GetOutputPort("payload.request"), estimator.GetInputPort("request"))
    builder.Connect(estimator.GetOutputPort("payload"), planner.GetInputPort("payload"))
    return estimator
