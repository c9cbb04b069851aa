"""A settled pile in the station and what the top camera sees of it."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.graspability import bin_roi
from tangle_drake.perception.camera import CameraModel, save_camera_json
from tangle_drake.scenario import Scenario
from tangle_drake.station import SimulatedStation, build_station, camera_model
from tangle_drake.station.bin_model import inner_corners
from tangle_drake.station.pile import PileReport, PileSettler


@dataclass
class Scene:
    """The station after a pile was dropped, with the camera's images of it."""

    station: SimulatedStation
    simulator: Simulator
    report: PileReport
    camera: CameraModel
    depth: np.ndarray
    """Metres along the optical axis, float32; NaN where nothing was seen."""
    rgb: np.ndarray
    floor_depth: float
    """Depth of the bin's floor under the camera, m (what an empty bin reads)."""
    timings: dict[str, float]
    views: dict[str, np.ndarray]
    """The scenario's view cameras' colour images, by camera name."""

    @property
    def context(self) -> Context:
        return self.simulator.get_context()

    def write(self, out: Path) -> None:
        """depth.npy (m), depth.png (16-bit mm, 0 = missing), rgb.png, camera.json, pile.json."""
        out.mkdir(parents=True, exist_ok=True)
        np.save(out / "depth.npy", self.depth)
        millimetres = np.nan_to_num(self.depth * 1000.0, nan=0.0, posinf=0.0)
        cv2.imwrite(str(out / "depth.png"), np.clip(millimetres, 0, 65535).astype(np.uint16))
        cv2.imwrite(str(out / "rgb.png"), cv2.cvtColor(self.rgb, cv2.COLOR_RGB2BGR))
        for name, image in self.views.items():
            cv2.imwrite(str(out / f"{name}.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
        save_camera_json(out / "camera.json", self.camera)
        (out / "pile.json").write_text(json.dumps(
            {"report": asdict(self.report), "parts": self.part_poses()}, indent=2))

    def label_image(self) -> np.ndarray:
        """Simulation-only ground truth: each pixel's body index (int16, H x W)."""
        image = self.station.GetOutputPort("sim.camera.label_image").Eval(self.context)
        return np.array(image.data, copy=True)[:, :, 0]

    def part_poses(self) -> dict[str, list[list[float]]]:
        """Model instance name -> 4x4 world pose of each part, from the simulator's state."""
        plant = self.station.plant
        poses = self.station.part_poses(self.context)
        return {plant.GetModelInstanceName(body.model_instance()): pose.tolist()
                for body, pose in zip(self.station.pile_bodies, poses, strict=True)}


def render_depth(station: Diagram, context: Context) -> np.ndarray:
    """The top camera's depth image in metres, float32 (H, W); NaN where nothing was seen."""
    image = station.GetOutputPort("camera.depth_image").Eval(context)
    depth = np.array(image.data, dtype=np.float32, copy=True)[:, :, 0]
    depth[~np.isfinite(depth)] = np.nan
    return depth


def render_rgb(station: Diagram, context: Context, camera: str = "camera") -> np.ndarray:
    """A camera's colour image, uint8 (H, W, 3) RGB (the top camera unless another port
    prefix is named, e.g. ``sim.overview`` for a view camera)."""
    image = station.GetOutputPort(f"{camera}.rgb_image").Eval(context)
    return np.array(image.data, copy=True)[:, :, :3]


def make_scene(scenario: Scenario, seed: int | None = None,
               progress: Callable[[str], None] | None = None) -> Scene:
    """Build the station, hold the robot still, drop a pile, and render the top camera."""
    camera = camera_model(scenario)
    if not bin_roi(camera, inner_corners(scenario.bin)).any():  # before any long work
        raise TangleDrakeError("the top camera sees nothing of the bin: check the scenario's "
                               "camera (camera_height, or camera.X_PB) and bin")
    timings: dict[str, float] = {}
    start = time.perf_counter()
    station = build_station(scenario)
    settler = PileSettler(station, scenario)
    timings["build_station"] = time.perf_counter() - start

    report = settler.settle(seed, progress).report
    simulator = settler.simulator
    timings["settle_pile"] = report.wall_time

    start = time.perf_counter()
    depth = render_depth(station, simulator.get_context())
    timings["render_depth"] = time.perf_counter() - start
    rgb = render_rgb(station, simulator.get_context())
    floor_depth = float(camera.X_WC[2, 3] - scenario.bin.floor_height)
    views = {config.name: render_rgb(station, simulator.get_context(), f"sim.{config.name}")
             for config in scenario.view_cameras}
    return Scene(station, simulator, report, camera, depth, rgb, floor_depth, timings, views)
