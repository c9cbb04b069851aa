"""The pick demo: a settled pile, then the pick diagram simulated until N picks are done.

``run_demo`` does what ``tangle-drake demo`` does, for scripts and tests; it reports through
a callback (``print`` by default) and returns the pick records.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from pydrake.geometry import Meshcat, MeshcatParams
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, EventStatus

from tangle_drake.common.errors import SafetyStop, TangleDrakeError
from tangle_drake.common.graphviz import write_graphviz
from tangle_drake.episode.episode import Episode
from tangle_drake.episode.run import (
    SIM_TIME_PER_PICK,
    PickRun,
    RunEnd,
)
from tangle_drake.parts import load_part
from tangle_drake.perception.crops import CropSpec
from tangle_drake.pick.diagram import (
    PickDiagram,
    closed_loop_settings,
    pick_settings,
    weighing_warning,
)
from tangle_drake.pick.meshcat_view import CandidateMarkers, frame_the_work
from tangle_drake.pick.outcome import PickRecord, summarize
from tangle_drake.pick.pick_log import PickLog, pick_log_identity
from tangle_drake.pick.pictures import PickPictures
from tangle_drake.pick.planner import PickSettings
from tangle_drake.planning.motions import motion_for
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.files import ScenarioSource, scenario_source
from tangle_drake.scenario.hardware import IN_PROCESS_URL
from tangle_drake.selection.choice import TangleChoice, model_part_notice, resolve_tangle_choice
from tangle_drake.selection.methods import MethodRun, choice_method
from tangle_drake.selection.rules import check_rule
from tangle_drake.station import SimulatedStation, camera_model
from tangle_drake.station.bin_model import inside_bin
from tangle_drake.station.pile import check_pile
from tangle_drake.tangle_cnn.model import load_tangle_model

RECORD_FPS = 20.0
"""Frames per second of ``--record``'s replay: smooth enough, and a third of Meshcat's 64,
which makes the replay file about that much smaller."""

HARDWARE_POLL = 0.05
"""Seconds between looks at the planner against a robot in real time: a safety stop ends the
demo this soon (in simulation, looks cost time and the episode's longer poll is kept)."""


@dataclass(frozen=True)
class DemoOptions:
    """What ``tangle-drake demo`` was asked for (``None``: the scenario's or the default)."""

    picks: int = 5
    part: str | None = None
    scenario: Scenario | ScenarioSource | str | Path | None = None
    """A scenario, its source (a base file and overlays), or its file (a shipped name such as
    ``pick_demo.yaml`` is found too)."""
    seed: int | None = None
    rule: str | None = None
    model: str | Path | None = None
    meshcat: bool = False
    record: Path | None = None
    diagram: Path | None = None
    hardware: bool = False
    """Pick through the hardware station (the robot's LCM driver messages)."""
    with_hardware_sim: bool = False
    """With ``hardware``: run the hardware simulator in this process, over ``memq://``."""
    open_loop: bool = False
    """Pick as the paper does: one look, one grasp, no weighing (``picks`` grasps, not
    deliveries)."""
    log_picks: Path | None = None
    """Append every weighed grasp to this pick log (``tangle_drake.pick.pick_log``)."""
    pictures: Path | None = None
    """Write a picture of each pick into this directory (``tangle_drake.pick.pictures``)."""


def with_part(scenario: Scenario, part: str | None) -> Scenario:
    """``scenario`` with its pile made of ``part`` only (:meth:`PileConfig.alone`); checks the
    part."""
    if part is None:
        return scenario
    load_part(part)  # a clear TangleDrakeError for an unknown part or a bad mesh
    return replace(scenario, pile=scenario.pile.alone(part))


def run_demo(options: DemoOptions, say: Callable[[str], None] = print) -> list[PickRecord]:
    """Build, drop a pile, pick ``options.picks`` times; returns the finished picks."""
    if options.picks < 1:
        raise TangleDrakeError(f"--picks must be at least 1, got {options.picks}")
    if options.record is not None and Path(options.record).suffix.lower() != ".html":
        raise TangleDrakeError(f"--record must name an .html file, not {options.record}")
    if options.with_hardware_sim and not options.hardware:
        raise TangleDrakeError("--with-hardware-sim goes with --hardware")
    if options.hardware and (options.meshcat or options.record or options.diagram):
        raise TangleDrakeError("--meshcat, --record and --diagram show the simulated station; "
                               "with --hardware there is none in the controller (run "
                               "`tangle-drake diagram` for the picture)")
    scenario = options.scenario if isinstance(options.scenario, Scenario) else \
        scenario_source(options.scenario).load()
    scenario = with_part(scenario, options.part)
    if scenario.pile.total_count == 0:
        raise TangleDrakeError("the scenario's pile has no parts: there is nothing to pick")
    for warning in check_pile(scenario):
        say(warning)
    open_loop = options.open_loop or not scenario.pick.closed_loop
    if options.log_picks is not None and open_loop:
        raise TangleDrakeError("--log-picks labels each grasp with its weighing, which the "
                               "open loop does not make: leave out --open-loop (or the "
                               "scenario's 'pick: {closed_loop: false}')")
    part = options.part or scenario.pile.parts[0].part
    if options.rule is None and scenario.pick.rule is not None:
        try:
            check_rule(scenario.pick.rule)
        except TangleDrakeError as error:
            raise TangleDrakeError(f"scenario field 'pick.rule': {error}") from error
    choice = resolve_tangle_choice(part, options.rule or scenario.pick.rule,
                                   options.model or scenario.pick.model)
    if choice.notice:
        say(choice.notice)
    if choice.model is not None and (mismatch := model_part_notice(choice.model, part)):
        say(mismatch)
    say(f"selection: rule {choice.rule}" + (f", model {choice.model}" if choice.model else ""))
    motion_for(scenario)  # before any long work: the scenario must have a robot
    settings = pick_settings(scenario, max_picks=options.picks) if open_loop \
        else closed_loop_settings(scenario, max_picks=options.picks)
    if not open_loop and (warning := weighing_warning(scenario)):
        say(warning)
    # Meshcat's candidate markers and the pictures are drawn from each look's record.
    settings = replace(settings, record_view=bool(options.meshcat or options.record
                                                  or options.pictures))
    if options.log_picks is None and options.pictures is None:
        return _run_demo(options, scenario, choice, settings, say, None)
    model = load_tangle_model(choice.model) if choice.model else None
    crop = model.crop if model is not None else CropSpec.for_gripper()
    settings = replace(settings, record_crop=crop)
    pictures = None if options.pictures is None else PickPictures(
        options.pictures, camera_model(scenario).intrinsics,
        model.normalisation if model is not None else None)
    if options.log_picks is None:
        return _run_demo(options, scenario, choice, settings, say, None, pictures)
    log = PickLog(options.log_picks, pick_log_identity(part, crop, DEFAULT_GRIPPER))
    for notice in log.notices:
        say(f"notice: {notice}")
    try:
        return _run_demo(options, scenario, choice, settings, say, log, pictures)
    finally:
        log.close()
        say(f"pick log {log.directory}: {log.logged} grasp(s) added"
            + (f", {log.skipped} not weighed or not tried, left out" if log.skipped else ""))


def _run_demo(options: DemoOptions, scenario: Scenario, choice: TangleChoice,
              settings: PickSettings, say: Callable[[str], None],
              log: PickLog | None, pictures: PickPictures | None = None) -> list[PickRecord]:
    if options.hardware:
        return _run_hardware(options, scenario, choice, settings, say, log, pictures)

    meshcat = None
    if options.meshcat or options.record:
        meshcat = Meshcat(MeshcatParams(host="localhost"))
        say(f"Meshcat: {meshcat.web_url()}")
    start = time.perf_counter()
    runner = Episode(scenario, [choice_method(choice)], None, settings, meshcat=meshcat)
    if meshcat is not None:
        frame_the_work(meshcat, scenario)
    pile = runner.settle(options.seed)
    say(f"pile: {pile.report.num_in_bin}/{pile.report.num_parts} parts in the bin, settled in "
        f"{pile.report.wall_time:.1f} s")
    if log is not None:
        log.pile_seed = pile.report.seed
    pick, episode = runner.pick_diagram, runner.episode
    if options.diagram is not None:
        write_graphviz(pick.diagram.GetGraphvizString(max_depth=1), Path(options.diagram))
        say(f"wrote {options.diagram}")
    runner.start(pile.state, MethodRun(choice.rule, scenario.random_seed))
    say(f"set-up {time.perf_counter() - start:.1f} s; picking {options.picks} part(s)")

    if meshcat is not None and options.record:
        meshcat.StartRecording(RECORD_FPS, set_visualizations_while_recording=options.meshcat)
    in_bin = _bin_count(pick, episode.simulator, scenario, scenario.pile.total_count)
    observers = [CandidateMarkers(meshcat).observer(pick, recording=bool(options.record))
                 ] if meshcat is not None else []
    if pictures is not None and scenario.view_cameras:
        observers.append(pictures.observer(pick, scenario.view_cameras[0]))
    if observers:
        episode.simulator.set_monitor(lambda root: _observe(observers, root))
    records = _run(runner, options.picks, say, in_bin,
                   closed=settings.recovery is not None, log=log, pictures=pictures)
    if meshcat is not None and options.record:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        Path(options.record).parent.mkdir(parents=True, exist_ok=True)
        Path(options.record).write_text(meshcat.StaticHtml())
        say(f"wrote {options.record}")
    say(f"{summarize(records)}; now {in_bin()}; wall time {time.perf_counter() - start:.0f} s")
    return records


def _observe(observers: list[Callable[[Context], None]], root: Context) -> EventStatus:
    """The simulator's monitor: each observer sees the root context after every step."""
    for observe in observers:
        observe(root)
    return EventStatus.Succeeded()


def _run_hardware(options: DemoOptions, scenario: Scenario, choice: TangleChoice,
                  settings: PickSettings, say: Callable[[str], None],
                  log: PickLog | None, pictures: PickPictures | None) -> list[PickRecord]:
    """The same pick diagram around the hardware station (:meth:`Episode.on_hardware`)."""
    start = time.perf_counter()
    episode = Episode.on_hardware(scenario, choice_method(choice), settings,
                                  MethodRun(choice.rule, scenario.random_seed),
                                  with_hardware_sim=options.with_hardware_sim,
                                  seed=options.seed, say=say)
    in_bin = None
    if (robot := episode.robot) is not None:
        say(f"hardware simulator and controller in this process over {IN_PROCESS_URL}; "
            f"set-up {time.perf_counter() - start:.1f} s; picking {options.picks} part(s)")
        in_bin = _bin_count(None, robot.simulator, scenario, robot.pile.num_in_bin,
                            robot.station)
        if log is not None:
            log.pile_seed = robot.pile.seed
    else:
        say(f"robot connected; picking {options.picks} part(s)")
    records = _run(episode, options.picks, say, in_bin, closed=settings.recovery is not None,
                   log=log, pictures=pictures,
                   poll=None if episode.robot is not None else HARDWARE_POLL)
    say(f"{summarize(records)}; " + ("" if in_bin is None else f"now {in_bin()}; ")
        + f"wall time {time.perf_counter() - start:.0f} s")
    return records


def parts_in_bin(station: SimulatedStation, context: Context, scenario: Scenario) -> int:
    """Simulation only: how many parts lie in the simulated ``station`` 's bin now (the
    released ones lie outside); ``context`` is its root diagram's."""
    return int(inside_bin(scenario.bin, station.part_poses(context)[:, :3, 3]).sum())


def _bin_count(pick: PickDiagram | None, simulator: Simulator, scenario: Scenario,
               total: int, station: SimulatedStation | None = None) -> Callable[[], str]:
    """Simulation only: "N of M parts in the bin" (and, with a tray monitor, "K in the tray")
    at the time it is called."""
    station = station if pick is None else pick.station

    def count() -> str:
        context = simulator.get_context()
        text = f"{parts_in_bin(station, context, scenario)} of {total} parts in the bin"
        if pick is not None and pick.tray is not None:
            tray = pick.tray.GetOutputPort("tray_count").Eval(
                pick.tray.GetMyContextFromRoot(context))
            text += f", {int(tray[0])} in the tray"
        return text

    return count


def _run(episode: Episode, picks: int, say: Callable[[str], None],
         in_bin: Callable[[], str] | None = None, closed: bool = False,
         log: PickLog | None = None, pictures: PickPictures | None = None,
         poll: float | None = None) -> list[PickRecord]:
    """Run the picks, reporting each as it ends (and adding it to ``log``); in simulation with
    what is left in the bin (``in_bin``), so a part that a pick pushed over the wall shows up
    at that pick. ``poll``: seconds between looks at the planner (default: the episode's)."""
    limit = picks * SIM_TIME_PER_PICK * (2 if closed else 1)

    def finished(record: PickRecord) -> None:
        say(record.describe() + ("" if in_bin is None else f" | {in_bin()}"))
        if log is not None:
            log.add(record)
        if pictures is not None:
            pictures.add(record)

    run: PickRun = episode.run(limit, on_pick=finished,
                               step=None if poll is None else lambda _: poll)
    if run.end is RunEnd.STOPPED:
        raise SafetyStop(f"safety stop after {len(run.records)} pick(s): "
                               f"{run.safety_message}; the robot holds where it is. Fix the "
                               "cause and run the demo again: it starts from the measured state.")
    elif run.end is RunEnd.TIMEOUT:
        say(f"stopped: {picks} pick(s) not done after {limit:.0f} s")
    return run.records
