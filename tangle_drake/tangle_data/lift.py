"""The force-based lift: a stiff spatial spring-damper pulls the target part straight up.

No fingers are simulated (the paper lifts the target "automatically"). Overwriting the
target's pose each step would lift nothing: it passes through its neighbours. Instead an
external spatial force on the target's centre of mass pulls it towards a set point that
starts at its settled pose and moves up along the lift path; the target's own weight is
compensated, nothing else's, so a part hooked on it adds its weight to the pull.

The force is recomputed from the state before every plant step and fixed on the plant's
``applied_spatial_force`` input (what a feedback LeafSystem would do, without needing the
station to export that port). Every part's rise is tracked at every step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
from pydrake.systems.analysis import Simulator

from tangle_drake.parts import PartModel
from tangle_drake.scenario import BinConfig
from tangle_drake.station.pile_freeze import PileFreeze, parts_beyond
from tangle_drake.tangle_data.settings import LiftSettings
from tangle_drake.tangle_data.support import Support, classify_support

_CHECK_STEPS = 5
"""Steps between checks whether the lift can end early (everything at rest in the hold, or
nothing more can come up: :meth:`ForceLift._outcome_is_settled`)."""
_CLEARANCE_M = 0.001
"""How far the rising group must be above every part it could touch to have left them."""
_REST_SPEED = 0.02
"""m/s: below this every part counts as at rest and the hold ends early."""


@dataclass(frozen=True)
class LiftResult:
    """What one lift did. Part indices are pile indices (order of ``part_bodies``)."""

    target: int
    rise: np.ndarray
    """(N,) largest rise of each part's centre of mass during the lift, m (target included)."""
    lifted: tuple[int, ...]
    """Other parts whose rise exceeded the threshold at some time."""
    hanging: tuple[int, ...]
    """Of ``lifted``: still up at the end, held by the lifted parts at or above their centre
    of mass (hooked, interlocked, pinched sideways)."""
    riding: tuple[int, ...]
    """Of ``lifted``: still up at the end, resting on the lifted parts from above."""
    target_rise: float
    """How far the target itself rose by the end, m."""
    stalled: bool
    """The lift ran to its end and the target rose less than the stall fraction of the lift
    height: the pile held it."""
    cleared: bool
    """The lift ended early, because nothing could change its record any more: the target
    and the parts it had lifted were above everything else they could touch, and nothing was
    on its way up (:meth:`ForceLift._outcome_is_settled`)."""
    steps: int
    """Plant steps simulated (the lift's cost)."""


class ForceLift:
    """Lifts one part of a settled pile in a station's simulator (reused across lifts)."""

    def __init__(self, simulator: Simulator, plant: MultibodyPlant, freeze: PileFreeze,
                 part: PartModel, points: np.ndarray, bin_config: BinConfig,
                 settings: LiftSettings) -> None:
        self.simulator = simulator
        self.freeze = freeze
        bodies = freeze.bodies
        self.bin = bin_config
        self.plant = plant
        self.bodies = bodies
        self.settings = settings
        self.dt = plant.time_step()
        omega = 2 * math.pi * settings.frequency_hz
        inertia_min = float(np.linalg.eigvalsh(part.inertia).min())
        self.k_lin = part.mass * omega**2
        self.d_lin = 2 * settings.damping_ratio * part.mass * omega
        self.k_rot = inertia_min * omega**2
        self.d_rot = 2 * settings.damping_ratio * inertia_min * omega
        self.max_torque = settings.max_force_n * part.bounding_radius
        self.weight = -part.mass * plant.gravity_field().gravity_vector()
        self.z_index = np.array([b.floating_positions_start() + 6 for b in bodies])
        self.points = points
        self.radius = part.bounding_radius
        self.reach = 2 * part.bounding_radius
        self.vz_index = np.array([b.floating_velocities_start_in_v() + 5 for b in bodies])
        self.g = float(np.linalg.norm(plant.gravity_field().gravity_vector()))
        self.port = plant.get_applied_spatial_force_input_port()

    def run(self, target: int, rise_threshold: float, stall_fraction: float) -> LiftResult:
        """Lift part ``target`` from the current state; the caller restores the pile after."""
        context = self.simulator.get_mutable_context()
        plant_context = self.plant.GetMyMutableContextFromRoot(context)
        body = self.bodies[target]
        X0 = body.EvalPoseInWorld(plant_context)
        p0, R0 = X0.translation().copy(), X0.rotation()
        z0 = self.plant.GetPositions(plant_context)[self.z_index]
        rise = np.zeros(len(self.bodies))
        force = ExternallyAppliedSpatialForce()
        force.body_index = body.index()
        force.p_BoBq_B = np.zeros(3)
        s = self.settings
        t0 = context.get_time()
        end_travel = s.travel_s
        steps = 0
        cleared = False
        self.freeze.freeze(context, self._far_from(target, context))
        try:
            while True:
                t = context.get_time() - t0
                if t >= end_travel + s.hold_s - 1e-9:
                    break
                if s.early_exit and steps % _CHECK_STEPS == 0 and steps > 0:
                    if t > end_travel and self._at_rest(plant_context):
                        break
                    if self._outcome_is_settled(plant_context, target, z0, rise_threshold):
                        cleared = True
                        break
                height, speed = _profile(t, s)
                X = body.EvalPoseInWorld(plant_context)
                V = body.EvalSpatialVelocityInWorld(plant_context)
                f = self.k_lin * (p0 + np.array([0.0, 0.0, height]) - X.translation()) + \
                    self.d_lin * (np.array([0.0, 0.0, speed]) - V.translational())
                f = _capped(f, s.max_force_n) + self.weight
                error = (R0 @ X.rotation().inverse()).ToAngleAxis()
                tau = self.k_rot * error.angle() * error.axis() - self.d_rot * V.rotational()
                force.F_Bq_W = SpatialForce(_capped(tau, self.max_torque), f)
                self.port.FixValue(plant_context, [force])
                self.simulator.AdvanceTo(t0 + (steps + 1) * self.dt)
                steps += 1
                z = self.plant.GetPositions(plant_context)[self.z_index]
                np.maximum(rise, z - z0, out=rise)
            final = self.plant.GetPositions(plant_context)[self.z_index] - z0
            lifted = tuple(int(n) for n in np.flatnonzero(rise > rise_threshold) if n != target)
            still_up = [n for n in lifted if final[n] > rise_threshold]
            support = classify_support(self.plant, plant_context, self.bodies, target, still_up)
        finally:
            self.port.FixValue(plant_context, [])
            self.freeze.thaw(context)
        return LiftResult(
            target=target, rise=rise, lifted=lifted,
            hanging=tuple(n for n in still_up if support[n] is Support.HANGS),
            riding=tuple(n for n in still_up if support[n] is Support.RIDES),
            target_rise=float(final[target]),
            stalled=not cleared and bool(final[target] < stall_fraction * s.height_m),
            cleared=cleared,
            steps=steps)

    def _far_from(self, target: int, context) -> list[int]:
        """Parts to freeze for this lift (see ``LiftSettings.freeze_beyond_radii``): far from
        the target, and in the bin (:mod:`tangle_drake.station.pile_freeze`)."""
        factor = self.settings.freeze_beyond_radii
        if factor == 0:
            return []
        centres = self.freeze.centres(context)
        return parts_beyond(centres, self.bin, centres[target], factor * self.radius)

    def _outcome_is_settled(self, plant_context, target: int, z0: np.ndarray,
                            threshold: float) -> bool:
        """Whether nothing can change the lift's record any more.

        The parts that are up (the target, and every part now more than the threshold above
        where it lay) are all above every other part that could touch one of them (centres
        closer than two bounding radii): the rising group can pick up nothing more. And no
        other part can still pass the threshold by coasting upward (rise + v_z^2 / 2g).
        The parts that are up stay counted as lifted even if they fall off later.
        """
        rise_now = self.plant.GetPositions(plant_context)[self.z_index] - z0
        v_z = self.plant.GetVelocities(plant_context)[self.vz_index].clip(min=0.0)
        up = rise_now > threshold
        up[target] = True
        if np.any(rise_now[~up] + v_z[~up] ** 2 / (2 * self.g) >= threshold):
            return False
        poses = [body.EvalPoseInWorld(plant_context) for body in self.bodies]
        rows = np.array([X.rotation().matrix()[2] for X in poses])
        centres = np.array([X.translation() for X in poses])
        z = self.points @ rows.T + centres[:, 2]  # (points, parts) heights of every surface
        bottom = z[:, up].min()
        gaps = np.linalg.norm(centres[:, None, :2] - centres[None, up, :2], axis=2)
        near = (gaps < self.reach).any(axis=1) & ~up
        return not np.any(z[:, near].max(axis=0) > bottom - _CLEARANCE_M)

    def _at_rest(self, plant_context) -> bool:
        v = self.plant.GetVelocities(plant_context)
        for body in self.bodies:
            start = body.floating_velocities_start_in_v()
            if np.linalg.norm(v[start + 3:start + 6]) > _REST_SPEED:
                return False
        return True


def _profile(t: float, s: LiftSettings) -> tuple[float, float]:
    """Set-point height and speed at time ``t`` of a trapezoidal lift (then a hold)."""
    ramp = s.ramp_s
    peak = s.accel_m_s2 * ramp
    travel = s.travel_s
    if t <= 0:
        return 0.0, 0.0
    if t < ramp:
        return 0.5 * s.accel_m_s2 * t * t, s.accel_m_s2 * t
    if t < travel - ramp:
        return 0.5 * peak * ramp + peak * (t - ramp), peak
    if t < travel:
        left = travel - t
        return s.height_m - 0.5 * s.accel_m_s2 * left * left, s.accel_m_s2 * left
    return s.height_m, 0.0


def _capped(vector: np.ndarray, limit: float) -> np.ndarray:
    norm = float(np.linalg.norm(vector))
    return vector if norm <= limit else vector * (limit / norm)
