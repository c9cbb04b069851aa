"""What a pick did: the outcome classes, the record of each pick, and the simulation-only
monitor that counts the parts the gripper brought up.

A robot alone can tell an empty grasp (the fingers closed further than any part allows), not
how many parts came up; in simulation, :class:`LiftMonitor` reads the true body poses (a
``sim.`` port no controller may use) and tells the planner, which records the count. On
hardware the count input stays unconnected and a held grasp is recorded as ``HELD``.
"""

from __future__ import annotations

import enum
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from tangle_drake.common.failures import FailureKind
from tangle_drake.pick.payload import PayloadEstimate
from tangle_drake.pick.recovery import Disposition, Recovery, Verdict
from tangle_drake.scenario import BinConfig
from tangle_drake.station import part_bodies
from tangle_drake.station.bin_model import inside_bin


class Outcome(enum.Enum):
    """How one pick ended."""

    ONE = "one part"
    """Exactly one part came up: the goal."""
    SEVERAL = "several parts"
    """More than one part came up: they were tangled."""
    NONE = "no part"
    """The gripper came up empty."""
    HELD = "held"
    """The gripper holds something; how much is unknown without a counter (hardware)."""
    FAILED = "failed"
    """Nothing was attempted: no candidate, or none the robot could reach without collision."""


@dataclass(frozen=True)
class Rejection:
    """A candidate turned down before the one that was tried."""

    rank: int
    """Its place in the selection's order (0 = the rule's choice)."""
    kind: FailureKind
    detail: str
    """For people: what the planner said."""

    @property
    def reason(self) -> str:
        return f"{self.kind.value}: {self.detail}"


VIEW_CANDIDATES = 5
"""How many of the rule's candidates a :class:`PickView` keeps."""


@dataclass(frozen=True)
class PickView:
    """What the planner saw when it chose a grasp (``PickSettings.record_view``)."""

    depth: np.ndarray
    """The top camera's depth image the grasp was chosen on, metres."""
    ranked: list
    """The first :data:`VIEW_CANDIDATES` ``ScoredCandidate`` in the rule's order (best
    first): each candidate, the model's probability (``None`` without one) and the rule's
    score."""


@dataclass(frozen=True)
class TrueCount:
    """Simulation only: what a pick truly brought up when the planner judged it (the episode
    fills it in from :class:`~tangle_drake.pick.truth.PickTruth`; ``None`` on hardware)."""

    lifted: int | None = None
    """Parts brought up when the planner looked."""
    held: int | None = None
    """Parts held up by the gripper through contacts then
    (:class:`~tangle_drake.pick.load_path.LoadPathMonitor`)."""
    resting: int | None = None
    """Of the ``held`` parts, how many still touched the pile or the bin then."""
    held_decided: int | None = None
    """Parts held up through contacts at the weighing that decided where the load went (the
    last one: after a shake it can differ from ``held``)."""


@dataclass(frozen=True)
class PickTiming:
    """How long a pick's stages took."""

    perception_s: float = 0.0
    """Wall time of rendering the depth image and the graspability index, s."""
    cnn_s: float = 0.0
    """Wall time of the tangle CNN and the selection rule, s."""
    planning_s: float = 0.0
    """Wall time of IK and trajectories, over every candidate tried, s."""
    execution_s: float = 0.0
    """Robot (simulated) time from the start of the approach to the return home, s."""
    started_at: float | None = None
    """Simulated (or controller) time at which the approach began, s."""

    @property
    def compute_s(self) -> float:
        """Wall time of perception, selection and planning, s."""
        return self.perception_s + self.cnn_s + self.planning_s


@dataclass
class PickRecord:
    """One finished pick: which grasp and why (the decision), what the robot saw come of it,
    what truly came up (``truth``, simulation only) and how long each stage took (``timing``)."""

    index: int
    """1 for the first pick of the run."""
    outcome: Outcome = Outcome.FAILED
    failure: FailureKind | None = None
    """Why it failed (``FAILED`` only; ``None`` otherwise)."""
    reason: str | None = None
    """The failure in words, for people (``FAILED`` only)."""
    candidate: Any = None
    """The grasp candidate tried (a ``GraspCandidate``), ``None`` if none was."""
    rank: int | None = None
    """The tried candidate's place in the selection's order."""
    p_model: float | None = None
    """The model's probability for the tried candidate, where a model ran."""
    p_model_name: str | None = None
    """What ``p_model`` is the probability of (``P(not tangled)``, ``P(success)``, ...)."""
    rejected: list[Rejection] = field(default_factory=list)
    width: float | None = None
    """Gripper opening measured after the lift, m."""
    truth_at: tuple[tuple[str, float], ...] = ()
    """When the planner judged the pick, by kind (:mod:`tangle_drake.pick.truth`): where the
    simulation's truth is taken, never by the planner itself."""
    truth: TrueCount = field(default_factory=TrueCount)
    """Simulation only: what truly came up then (all ``None`` on hardware)."""
    timing: PickTiming = field(default_factory=PickTiming)
    estimate: PayloadEstimate | None = None
    """Closed loop: the first weighing at the top of the lift."""
    verdict: Verdict | None = None
    """Closed loop: what that weighing (and the fingers) said came up."""
    recoveries: list[Recovery] = field(default_factory=list)
    """Closed loop: what was done about it, in order (weighing again, shaking, putting back;
    stirring the bin, after a look that found nothing to pick or the last of
    ``RecoverySettings.max_attempts`` grasps without a delivery)."""
    disposition: Disposition | None = None
    """Closed loop: how the grasp ended (delivered to the tray, empty, put back)."""
    crop: np.ndarray | None = None
    """With ``PickSettings.record_crop``: the tried candidate's depth crop (metres) in the
    image it was chosen from, as the tangle CNN sees it."""
    view: PickView | None = None
    """With ``PickSettings.record_view``: the image and candidates the grasp was chosen from."""

    def describe(self) -> str:
        """One line for people: the outcome (and, closed loop, the weighing and what was done
        about it), then the timings."""
        if self.outcome is Outcome.FAILED:
            what = f"failed: {self.reason}"
        else:
            what = self.outcome.value
            if self.truth.lifted is not None and self.outcome is Outcome.SEVERAL:
                what += f" ({self.truth.lifted})"
        tried = ""
        if self.candidate is not None:
            p = "" if self.p_model is None else f", {self.p_model_name} {self.p_model:.2f}"
            rejected = f", {len(self.rejected)} rejected before" if self.rejected else ""
            tried = (f" | candidate #{self.rank} (graspability {self.candidate.score:.2f}{p}"
                     f"{rejected})")
        if self.disposition is not None:
            weighed = "" if self.estimate is None or not self.estimate.ready else (
                f"weighed {self.estimate.parts:.2f} parts, ")
            steps = "".join(f"{r.value}, " for r in self.recoveries if r is not Recovery.STIR)
            tried += f" | {weighed}{steps}{self.disposition.value}"
        if Recovery.STIR in self.recoveries:
            tried += f" | then {Recovery.STIR.value}"
        t = self.timing
        return (f"pick {self.index}: {what}{tried} | perception {t.perception_s * 1e3:.0f} ms, "
                f"CNN {t.cnn_s * 1e3:.0f} ms, planning {t.planning_s * 1e3:.0f} ms, "
                f"execution {t.execution_s:.1f} s")


def classify_lift(width: float, lifted: int | None, empty_width: float) -> Outcome:
    """How a pick ended, judged at the top of the lift: fingers closed past ``empty_width``
    hold nothing (all a robot can tell); else the simulation's count of parts brought up,
    where there is one (``None``: hardware, ``HELD``), says one or several."""
    if width < empty_width or lifted == 0:
        return Outcome.NONE
    if lifted is None:
        return Outcome.HELD
    return Outcome.ONE if lifted == 1 else Outcome.SEVERAL


def summarize(records: Sequence[PickRecord]) -> str:
    """One line: how many picks ended how."""
    counts = Counter(record.outcome for record in records)
    parts = [f"{counts[outcome]} {outcome.value}" for outcome in Outcome if counts[outcome]]
    text = f"{len(records)} pick(s): " + (", ".join(parts) if parts else "none")
    dispositions = Counter(r.disposition for r in records if r.disposition is not None)
    if dispositions:
        text += " (" + ", ".join(f"{dispositions[d]} {d.value}" for d in Disposition
                                 if dispositions[d]) + ")"
    return text


class LiftMonitor(LeafSystem):
    """Simulation only: the number of parts hanging from the gripper, from true body poses.

    A part counts when its centre is more than ``margin`` above the bin's rim and within
    ``radius`` (horizontally) of the gripper: above the rim it cannot be lying in the bin, and
    near the gripper it is not a part that was flung out. Input ``body_poses`` takes the
    station's ``sim.body_poses``; output ``lifted_count`` is a 1-vector.
    """

    def __init__(self, plant: MultibodyPlant, bin_config: BinConfig, margin: float = 0.02,
                 radius: float = 0.15, gripper_body: str = "gripper_base") -> None:
        super().__init__()
        self._parts = [int(body.index()) for body in part_bodies(plant)]
        self._gripper = int(plant.GetBodyByName(gripper_body).index())
        self._height = bin_config.floor_height + bin_config.wall_height + margin
        self._radius = radius
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate())
        self.DeclareVectorOutputPort("lifted_count", 1, self._calc_count)

    def lifted_parts(self, context: Context) -> list[int]:
        """Body indices of the parts counted now."""
        poses = self._poses.Eval(context)
        p_gripper = poses[self._gripper].translation()
        lifted = []
        for index in self._parts:
            p = poses[index].translation()
            if p[2] > self._height and np.linalg.norm(p[:2] - p_gripper[:2]) < self._radius:
                lifted.append(index)
        return lifted

    def _calc_count(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, float(len(self.lifted_parts(context))))


class TrayMonitor(LeafSystem):
    """Simulation only: the number of parts lying in the output tray, from true body poses
    (what a closed-loop run delivered, counted by the simulation, not by the estimator).

    A part counts when its centre of mass is within ``reach`` of the tray's floor (a hook's
    centre of mass lies off its wire, and may be past the walls of a part lying in the tray)
    and below the rim plus ``margin`` (one still hanging from the gripper does not; one that
    fell beside the tray lies on the ground, far below). Input ``body_poses``, output
    ``tray_count``.
    """

    def __init__(self, plant: MultibodyPlant, tray: BinConfig, margin: float = 0.02,
                 reach: float = 0.05) -> None:
        super().__init__()
        self._parts = [int(body.index()) for body in part_bodies(plant)]
        self._tray = tray
        self._reach = reach
        self._top = tray.floor_height + tray.wall_height + margin
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate())
        self.DeclareVectorOutputPort("tray_count", 1, self._calc_count)

    def in_tray(self, p_W: np.ndarray) -> np.ndarray:
        """Whether parts' centres of mass at world point(s) (..., 3) count as in the tray."""
        p_W = np.asarray(p_W, float)
        return inside_bin(self._tray, p_W, margin=-self._reach) & (p_W[..., 2] < self._top)

    def parts_in_tray(self, context: Context) -> list[int]:
        """Body indices of the parts in the tray now."""
        poses = self._poses.Eval(context)
        return [i for i in self._parts if self.in_tray(poses[i].translation())]

    def _calc_count(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, float(len(self.parts_in_tray(context))))
