"""A picture per pick (``tangle-drake demo --pictures DIR``): what the camera saw, which grasps
were ranked, which one was chosen, and what came up.

Each picture holds, left, the top camera's depth view with the rule's first candidates drawn
(the hands of graspability's overlay) and the chosen one marked by a cyan dot and ring at its
centre, above a table of their scores (graspability, the model's P, the rule's); right, the
side view at the top of the lift (the scenario's first view camera, in simulation, cut out
around the gripper), captioned with the outcome, above the tangle CNN's crop of the chosen
grasp and its target mask. On hardware, where there is no side view, that panel shows the
wrist's weighing instead.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
from pydrake.systems.framework import Context
from pydrake.systems.sensors import CameraConfig

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.graspability.overlay import top_view
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.pick.diagram import PickDiagram
from tangle_drake.pick.outcome import Outcome, PickRecord
from tangle_drake.pick.planner import Mode
from tangle_drake.planning.planning_model import TCP_FRAME
from tangle_drake.station import SIM_ONLY_PREFIX
from tangle_drake.tangle_cnn.normalise import Normalisation

CHOSEN = (255, 255, 0)
"""BGR of the chosen grasp's marker (cyan: no candidate colour and no grey of the depth)."""
TILE = 192
"""Pixels of the crop and mask tiles."""
_LINE = 22
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_LIFT_TOP = (Mode.WEIGH, Mode.CHECK)
"""The planner's modes at the top of the lift (closed loop, open loop)."""


def _text(image: np.ndarray, text: str, origin: tuple[int, int], scale: float = 0.5,
          colour: tuple[int, int, int] = (255, 255, 255)) -> None:
    cv2.putText(image, text, origin, _FONT, scale, colour, 1, cv2.LINE_AA)


def _fit(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """``image`` scaled to fit ``width`` x ``height``, on black."""
    out = np.zeros((height, width, 3), np.uint8)
    scale = min(width / image.shape[1], height / image.shape[0])
    w, h = int(image.shape[1] * scale), int(image.shape[0] * scale)
    out[:h, :w] = cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA)
    return out


def _grey(values: np.ndarray) -> np.ndarray:
    low, high = float(np.min(values)), float(np.max(values))
    scaled = (values - low) / (high - low) if high > low else np.zeros_like(values)
    grey = (255 * np.clip(scaled, 0, 1)).astype(np.uint8)
    return cv2.cvtColor(cv2.resize(grey, (TILE, TILE), interpolation=cv2.INTER_NEAREST),
                        cv2.COLOR_GRAY2BGR)


def outcome_caption(record: PickRecord) -> str:
    """One line: the pick, what came up, and what the wrist weighed."""
    what = f"failed: {record.failure.value}" if record.outcome is Outcome.FAILED \
        else record.outcome.value
    estimate = record.estimate
    weighed = f", weighed {estimate.parts:.2f} parts" if estimate is not None and \
        estimate.ready else ""
    done = f", {record.disposition.value}" if record.disposition is not None else ""
    return f"pick {record.index}: {what}{weighed}{done}"


def pick_picture(record: PickRecord, intrinsics: CameraIntrinsics,
                 side_view: np.ndarray | None = None,
                 normalisation: Normalisation | None = None) -> np.ndarray:
    """The picture of one pick (BGR); ``record`` must have its ``view``. ``side_view`` (RGB or
    RGBA) is the scene at the top of the lift; ``normalisation`` gives the crop its target
    mask (the model's; default: none drawn)."""
    if record.view is None:
        raise ValueError("the record has no view: pick with PickSettings.record_view")
    width, height = intrinsics.width, intrinsics.height
    band = max(_LINE * (len(record.view.ranked) + 2), TILE + 2 * _LINE)
    picture = np.zeros((height + band, 2 * width, 3), np.uint8)

    top = top_view(record.view.depth, [s.candidate for s in record.view.ranked], intrinsics)
    chosen = record.candidate
    if chosen is not None:
        centre = (int(np.rint(chosen.u)), int(np.rint(chosen.v)))
        cv2.circle(top, centre, 14, CHOSEN, 2, cv2.LINE_AA)
        cv2.circle(top, centre, 4, CHOSEN, -1)
    picture[:height, :width] = top
    name = next((s.p_model_name for s in record.view.ranked if s.p_model_name), "model")
    _text(picture, f"rank  graspability  {name:<14}  rule's score", (8, height + _LINE))
    for rank, scored in enumerate(record.view.ranked):
        p = "   -  " if scored.p_model is None else f"{scored.p_model:5.2f} "
        mark = "  <- chosen" if chosen is not None and scored.candidate is chosen else ""
        _text(picture, f"#{rank + 1}      {scored.candidate.score:5.2f}          {p}"
                       f"          {scored.score:5.2f}{mark}",
              (8, height + _LINE * (rank + 2)), colour=CHOSEN if mark else (220, 220, 220))

    if side_view is not None:
        picture[:height, width:] = _fit(cv2.cvtColor(side_view[..., :3], cv2.COLOR_RGB2BGR),
                                        width, height)
    else:
        _text(picture, "no side view (hardware): the wrist's weighing", (width + 8, 3 * _LINE))
        estimate = record.estimate
        if estimate is not None and estimate.ready:
            lines = [f"{estimate.parts:.2f} +- {estimate.std:.2f} parts "
                     f"(support {estimate.support:.2f} N, one part {estimate.part_weight:.3f} N)",
                     f"count {estimate.count}, confidence {estimate.confidence:.2f}"
                     + (", swinging" if estimate.swinging else "")]
            for k, line in enumerate(lines):
                _text(picture, line, (width + 8, (5 + k) * _LINE))
    _text(picture, outcome_caption(record), (width + 8, _LINE), 0.6, CHOSEN)
    if record.crop is not None:
        x, y = width + 8, height + _LINE
        _text(picture, "the CNN's crop", (x, y))
        picture[y + 8:y + 8 + TILE, x:x + TILE] = _grey(record.crop.max() - record.crop)
        if normalisation is not None and normalisation.target_mask is not None:
            mask = normalisation.masks(record.crop[None], np.array([chosen.depth_m]))[0]
            _text(picture, "its target mask", (x + TILE + 16, y))
            picture[y + 8:y + 8 + TILE, x + TILE + 16:x + 2 * TILE + 16] = _grey(mask)
    return picture


class _ViewFrame:
    """Where a view camera sees a world point, to cut out the gripper's surroundings."""

    WINDOW_M = (0.48, 0.36)
    """Width and height of the cut-out at the gripper, m."""
    BELOW_M = 0.03
    """Its centre lies this far below the tool centre, m (parts hang below the fingers)."""

    def __init__(self, config: CameraConfig) -> None:
        color, _ = config.MakeCameras()
        info = color.core().intrinsics()
        self._f = np.array([info.focal_x(), info.focal_y()])
        self._c = np.array([info.center_x(), info.center_y()])
        X_WC = config.X_PB.GetDeterministicValue() @ color.core().sensor_pose_in_camera_body()
        self._X_CW = X_WC.inverse()

    def around(self, image: np.ndarray, p_WT: np.ndarray) -> np.ndarray:
        """The part of ``image`` (RGB(A)) around the tool centre ``p_WT`` (the whole image if
        it is behind the camera or out of view)."""
        p_C = self._X_CW @ (np.asarray(p_WT) - np.array([0.0, 0.0, self.BELOW_M]))
        if p_C[2] <= 0:
            return image
        centre = self._f * p_C[:2] / p_C[2] + self._c
        half = self._f * np.array(self.WINDOW_M) / p_C[2] / 2
        (u0, v0), (u1, v1) = np.rint(centre - half).astype(int), np.rint(centre + half).astype(int)
        rows, cols = image.shape[:2]
        u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, cols), min(v1, rows)
        return image if u1 - u0 < 8 or v1 - v0 < 8 else image[v0:v1, u0:u1]


class PickPictures:
    """Writes ``DIR/pick_NNN.png`` for each pick (see the module docstring)."""

    def __init__(self, directory: Path, intrinsics: CameraIntrinsics,
                 normalisation: Normalisation | None = None) -> None:
        self.directory = Path(directory)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise TangleDrakeError(f"cannot make the pictures directory {directory}: "
                                   f"{error.strerror}") from None
        self._intrinsics = intrinsics
        self._normalisation = normalisation
        self._side: dict[int, np.ndarray] = {}
        self.written: list[Path] = []

    def observer(self, pick: PickDiagram, view: CameraConfig) -> Callable[[Context], None]:
        """What the simulator's monitor calls with the root context after each step: renders
        the view camera ``view`` (one of the scenario's ``view_cameras``) once per grasp as
        the lift reaches its top, and keeps the part of it around the gripper (the fingers
        and what hangs below them)."""
        station, diagram = pick.station, pick.diagram
        mode_port, picks_port = diagram.GetOutputPort("mode"), diagram.GetOutputPort("picks")
        camera = station.GetOutputPort(f"{SIM_ONLY_PREFIX}{view.name}.rgb_image")
        plant = station.plant
        tcp = plant.GetFrameByName(TCP_FRAME)
        frame = _ViewFrame(view)
        before = [Mode.SETTLE]

        def observe(root: Context) -> None:
            mode = mode_port.Eval(root)
            if mode in _LIFT_TOP and before[0] not in _LIFT_TOP:
                index = len(picks_port.Eval(root)) + 1
                if index not in self._side:  # the first weighing: what the lift brought up
                    image = np.array(camera.Eval(station.GetMyContextFromRoot(root)).data)
                    p_WT = tcp.CalcPoseInWorld(plant.GetMyContextFromRoot(root)).translation()
                    self._side[index] = frame.around(image, p_WT)
            before[0] = mode

        return observe

    def add(self, record: PickRecord) -> None:
        """Write the picture of ``record`` (a pick made with ``record_view``)."""
        if record.view is None:
            return  # nothing was looked at (a gave-up record)
        path = self.directory / f"pick_{record.index:03d}.png"
        picture = pick_picture(record, self._intrinsics, self._side.pop(record.index, None),
                               self._normalisation)
        if not cv2.imwrite(str(path), picture):
            raise TangleDrakeError(f"cannot write {path}")
        self.written.append(path)
