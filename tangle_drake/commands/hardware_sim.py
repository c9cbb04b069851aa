"""``tangle-drake hardware-sim``: the simulated robot, gripper, camera and pile behind LCM."""

from __future__ import annotations

import argparse
import logging
import math
import time

from tangle_drake.commands.arguments import add_scenario_argument, add_seed_argument, scenario_from
from tangle_drake.common.errors import TangleDrakeError

CHECK_TIMEOUT = 10.0
"""Simulated seconds ``--check`` allows its scripted motion."""
LAG_REPORT = 0.05
"""How much more the simulator must fall behind real time before it says so again, s."""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "hardware-sim", help="simulate the robot behind its LCM driver messages",
        description="Simulate the Nextage, its gripper, the top camera and a settled pile, and "
                    "speak only the robot's driver messages (lcmt_iiwa_command/status, "
                    "lcmt_schunk_wsg_command/status, lcmt_image_array) on the scenario's LCM "
                    "bus, like Drake's hardware_sim. The bus must be a network URL set in the "
                    "scenario's lcm_buses (the default memq:// reaches no other process); "
                    "--check instead drives it in this process with a scripted controller "
                    "through the hardware station, over memq:// only.")
    add_scenario_argument(parser)
    add_seed_argument(parser, None, help="pile seed (default: the scenario's pile.seed)")
    parser.add_argument("--duration", type=float, default=math.inf,
                        help="simulated seconds to run (default: until interrupted)")
    parser.add_argument("--check", action="store_true",
                        help="run a scripted arm move and gripper close/open through the "
                             "hardware station in this process, and report how it went")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:

    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    if not args.duration > 0:
        raise TangleDrakeError(f"--duration must be positive, got {args.duration:g}")
    scenario = scenario_from(args).load()
    return _check(scenario, args.seed) if args.check else _serve(scenario, args)


def _serve(scenario, args: argparse.Namespace) -> int:
    from tangle_drake.hardware.hardware_sim import build_hardware_sim
    from tangle_drake.lcm_io.buses import network_bus_url

    url = network_bus_url(scenario, "use --check to drive the simulator from this process")
    sim = build_hardware_sim(scenario, seed=args.seed, progress=print)
    channels = " and ".join(c.command_channel for c in scenario.model_drivers.values())
    print(f"hardware simulator on {url}: pile of {sim.pile.num_in_bin} parts; commands on "
          f"{channels}")
    sim.simulator.set_target_realtime_rate(1.0)
    start = time.perf_counter()
    reported_lag = 0.0
    while (now := sim.simulator.get_context().get_time()) < args.duration:
        before = time.perf_counter()
        sim.simulator.AdvanceTo(min(now + 1.0, args.duration))
        rate = (sim.simulator.get_context().get_time() - now) / (time.perf_counter() - before)
        now = sim.simulator.get_context().get_time()
        wall = time.perf_counter() - start
        line = f"t = {now:.1f} s (wall {wall:.1f} s)"
        # Ahead of real time the simulator waits; behind it, the lag only grows.
        if wall - now > reported_lag + LAG_REPORT:
            reported_lag = wall - now
            line += (f": behind real time by {reported_lag:.2f} s, at {rate:.2f} x real time "
                     "in this second (the robot moves and reports slower than the controller "
                     "expects)")
        print(line, flush=True)
    return 0


def _check(scenario, seed: int | None) -> int:
    import numpy as np

    from tangle_drake.drivers.registry import carrier
    from tangle_drake.hardware.loop import HardwareInTheLoop
    from tangle_drake.hardware.scripted import scripted_controller, scripted_target

    start = time.perf_counter()
    loop = HardwareInTheLoop(scenario, scripted_controller, seed=seed, progress=print)
    done_port = loop.controller_diagram.GetOutputPort("script.done")
    station_context = loop.station.GetMyContextFromRoot(loop.controller.get_context())
    widths = []

    def done(_: HardwareInTheLoop) -> bool:
        widths.append(loop.station.GetOutputPort("gripper.state_measured")
                      .Eval(station_context)[0])
        return done_port.Eval(loop.controller.get_context())[0] > 0.5

    finished = loop.advance_until(done, CHECK_TIMEOUT)
    report = loop.station.GetOutputPort("safety.report").Eval(station_context)
    name, _ = carrier(scenario.model_drivers)
    q = loop.station.GetOutputPort(f"{name}.position_measured").Eval(station_context)
    error = float(np.max(np.abs(q - scripted_target(scenario))))
    print(f"scripted motion {'finished' if finished else 'did not finish'} at t = "
          f"{loop.time:.2f} s ({time.perf_counter() - start:.1f} s wall): {name} within "
          f"{error:.4f} of its target, gripper closed to {1e3 * min(widths):.1f} mm and "
          f"opened to {1e3 * widths[-1]:.1f} mm; safety {report.mode.value}"
          f"{': ' + report.message if report.message else ''}; malformed status messages "
          f"{sum(report.rejected)}")
    return 0 if finished and report.message == "" else 1
