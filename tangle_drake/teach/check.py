"""The mesh check: is this a part the cell can learn, and did we understand it?

Before any long work, ``tangle-drake teach`` says what it made of the user's mesh: its size in
metres (a wrong ``--mesh-scale`` shows at once), the mass and inertia the physics will use and
where the mass came from, whether the mesh was watertight and what the repair did, how many
convex pieces CoACD cut it into and how much their volume exceeds the part's (the collisions'
error), and pictures. A mesh that is not a part the cell can pick is refused with the reason:
no triangles, a flat sheet with no volume, larger than the bin, smaller than a finger is wide,
or heavier than the fingers hold.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import trimesh

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.parts import BUILTIN_PARTS, cache, load_part
from tangle_drake.parts.build import wire_body
from tangle_drake.parts.catalog import builtin_spec
from tangle_drake.parts.library import PART_FILE_SUFFIX, STEEL_DENSITY, read_part_file
from tangle_drake.parts.mesh_import import MESH_SUFFIXES
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.scenario import PartCount, Scenario
from tangle_drake.station.pile import PileReport, check_pile

MIN_THICKNESS_M = 0.0005
"""A part thinner than this in every direction but two is a flat sheet: no volume to weigh
or to hold."""


@dataclass(frozen=True)
class PartCheck:
    """What the check found; ``refusal`` says why the part cannot be taught (else ``None``)."""

    mesh: str
    name: str | None = None
    size_m: tuple[float, float, float] | None = None
    """The mesh's bounding box, metres, after ``--mesh-scale``."""
    mass_kg: float | None = None
    mass_from: str | None = None
    """``mesh`` (a closed surface), ``voxel_fill`` or ``convex_pieces`` (a surface the repair
    could not close), ``weighed`` (the user's ``--mass``), ``wire`` (a built-in part's)."""
    inertia_kg_m2: list | None = None
    """About the centre of mass, in the mesh's axes."""
    watertight: bool | None = None
    """Whether the file as given was a closed surface."""
    holes_capped: int = 0
    pieces: int | None = None
    pieces_volume_ratio: float | None = None
    """The convex pieces' summed volume over the part's: how much larger the part collides."""
    pile: str | None = None
    """How a settled pile of the part went (after the pictures)."""
    refusal: str | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def accepted(self) -> bool:
        return self.refusal is None

    def lines(self) -> list[str]:
        """The check for people, one fact a line."""
        if self.size_m is None:
            return [f"mesh {self.mesh}: refused: {self.refusal}"]
        size = " x ".join(f"{1000 * s:.1f}" for s in self.size_m)
        what = "built-in part" if self.mass_from == "wire" else "mesh"
        lines = [f"{what} {self.mesh} ({self.name}): {size} mm",
                 f"mass {1000 * self.mass_kg:.2f} g ({self.mass_from}); inertia diagonal "
                 + ", ".join(f"{x:.3g}" for x in np.diag(self.inertia_kg_m2)) + " kg m^2",
                 "watertight as given" if self.watertight else
                 f"not watertight as given: {self.holes_capped} hole(s) capped"
                 + ("" if self.mass_from in ("mesh", "weighed") else
                    f"; still open, so the mass is from a {self.mass_from.replace('_', ' ')}"),
                 f"{self.pieces} convex collision pieces, "
                 f"{100 * (self.pieces_volume_ratio - 1):+.1f} % of the part's volume"]
        lines += [self.pile] if self.pile else []
        lines += [w if w.startswith("warning:") else f"warning: {w}" for w in self.warnings]
        lines.append("accepted" if self.accepted else f"refused: {self.refusal}")
        return lines

    def write(self, path: Path) -> None:
        path.write_text(json.dumps(asdict(self), indent=1) + "\n")


def check_part(mesh: Path | str, mesh_scale: float, scenario: Scenario,
               gripper: GripperSpec = DEFAULT_GRIPPER) -> PartCheck:
    """Check ``mesh`` at ``mesh_scale`` for ``scenario``'s bin and the ``gripper``; a part file
    (its own scale; ``mesh_scale`` 1) brings the mass the user weighed. A built-in part's name
    checks that part (its mass from its wire, its collisions the wire's capsules)."""
    if str(mesh) in BUILTIN_PARTS:
        return _check_builtin(str(mesh), mesh_scale, scenario, gripper)
    mesh = Path(mesh)
    source, weighed = mesh, None
    try:
        if mesh.suffix.lower() == PART_FILE_SUFFIX:
            source, _, weighed = read_part_file(mesh)
        if source.suffix.lower() not in MESH_SUFFIXES:
            return PartCheck(str(mesh), refusal=f"not a mesh file: {source} (give an .obj, "
                                                ".stl or .ply)")
        part = load_part(mesh, mesh_scale=mesh_scale)  # a part file: at the weighed mass
        solid = load_part(source, mesh_scale=part_scale(mesh, mesh_scale))  # at steel
    except TangleDrakeError as error:
        return PartCheck(str(mesh), refusal=str(error))
    entry = solid.sdf_path.parent
    meta = json.loads((entry / cache.META_FILE).read_text())
    surface = trimesh.load_mesh(part.visual_mesh_path, process=False)
    size = tuple(float(x) for x in surface.extents)
    pieces = [trimesh.load_mesh(p, process=False) for p in sorted(entry.glob("collision_*.obj"))]
    volume = solid.mass / STEEL_DENSITY  # what the mass was integrated over
    ratio = sum(float(p.volume) for p in pieces) / volume if pieces else 1.0
    check = PartCheck(str(mesh), part.name, size, float(part.mass),
                      "weighed" if weighed is not None else meta["mass_from"],
                      np.asarray(part.inertia).tolist(), _was_watertight(source),
                      int(meta["holes_capped"]), len(pieces), float(ratio))
    return _refusal(check, mesh, mesh_scale, scenario, gripper)


def _check_builtin(name: str, scale: float, scenario: Scenario,
                   gripper: GripperSpec) -> PartCheck:
    part = load_part(name, mesh_scale=scale)
    surface = trimesh.load_mesh(part.visual_mesh_path, process=False)
    pieces = collision_pieces(name, scale)
    volume = part.mass / STEEL_DENSITY
    ratio = sum(float(p.volume) for p in pieces) / volume
    check = PartCheck(name, part.name, tuple(float(x) for x in surface.extents),
                      float(part.mass), "wire", np.asarray(part.inertia).tolist(), True, 0,
                      len(pieces), float(ratio))
    return _refusal(check, name, scale, scenario, gripper)


def collision_pieces(part: str | Path, mesh_scale: float = 1.0) -> list[trimesh.Trimesh]:
    """The part's collision shapes as meshes in its body frame, for the pictures: a mesh
    part's convex pieces, a built-in part's capsules along its wire."""
    if str(part) not in BUILTIN_PARTS:
        entry = load_part(part, mesh_scale=mesh_scale).sdf_path.parent
        return [trimesh.load_mesh(p, process=False)
                for p in sorted(entry.glob("collision_*.obj"))]
    _, _, capsules = wire_body(builtin_spec(str(part)).scaled(mesh_scale), STEEL_DENSITY)
    pieces = []
    for capsule in capsules:
        axis = capsule.end - capsule.start
        piece = trimesh.creation.capsule(height=float(np.linalg.norm(axis)),
                                         radius=capsule.radius)
        piece.apply_transform(trimesh.geometry.align_vectors([0.0, 0.0, 1.0], axis))
        piece.apply_translation((capsule.start + capsule.end) / 2)
        pieces.append(piece)
    return pieces


def part_scale(mesh: Path, mesh_scale: float) -> float:
    """The mesh's scale: a part file's own, else ``mesh_scale``."""
    return read_part_file(mesh)[1] if Path(mesh).suffix.lower() == PART_FILE_SUFFIX \
        else mesh_scale


def _was_watertight(source: Path) -> bool:
    try:
        return bool(trimesh.load_mesh(source, process=True).is_watertight)
    except Exception:  # it loaded through the repairing reader; as given it did not
        return False


def _refusal(check: PartCheck, source: Path | str, scale: float, scenario: Scenario,
             gripper: GripperSpec) -> PartCheck:
    size = sorted(check.size_m)
    reason = None
    if size[0] < MIN_THICKNESS_M:
        reason = (f"a flat sheet: {1000 * size[0]:.2f} mm thick, so it has no volume to weigh "
                  "or hold (a surface, not a solid? check the export)")
    elif size[2] < gripper.finger_width:
        reason = (f"smaller than a finger is wide: {1000 * size[2]:.1f} mm across, the fingers "
                  f"{1000 * gripper.finger_width:.0f} mm (check --mesh-scale: metres per unit)")
    else:
        one = replace(scenario, pile=replace(scenario.pile,
                                             parts=[PartCount(str(source), 1, scale)]))
        try:
            check_pile(one, gripper)  # too large for the bin, too heavy for the fingers
        except TangleDrakeError as error:
            reason = str(error)
        else:
            return replace(check, warnings=check_pile(scenario_of(scenario, source, scale),
                                                      gripper))
    return replace(check, refusal=reason)


MAX_PARKED_SHARE = 0.2
"""A pile in which the settler had to take more than this share of the parts out of the bin
(they stuck in each other or left the bin) is one the physics cannot make of this part."""


def settle_verdict(check: PartCheck, report: PileReport) -> PartCheck:
    """``check`` with what a settled pile of the part showed: a line on how it went, and a
    refusal if the simulation could not pile it (a part thin enough to sink through others at
    the plant's step, say)."""
    line = (f"a pile of {report.num_parts}: {report.num_in_bin} settled in the bin in "
            f"{report.settle_time:.1f} s simulated, {len(report.redrawn)} redrawn, "
            f"{len(report.parked)} parked, deepest overlap "
            f"{1000 * report.max_penetration:.1f} mm")
    check = replace(check, pile=line)
    if len(report.parked) <= MAX_PARKED_SHARE * report.num_parts:
        return check
    thinnest = 1000 * min(check.size_m)
    return replace(check, refusal=(
        f"the simulation cannot pile this part: {len(report.parked)} of {report.num_parts} "
        f"parts stuck in each other or left the bin (overlaps up to "
        f"{1000 * report.max_penetration:.1f} mm): the contact model cannot hold this shape "
        f"(thin parts, here {thinnest:.1f} mm, can pass through each other within a step of "
        "the plant's 2 ms)"))


def scenario_of(scenario: Scenario, part: str | Path, mesh_scale: float = 1.0) -> Scenario:
    """``scenario`` with its pile made of ``part`` alone (:meth:`PileConfig.alone`)."""
    return replace(scenario, pile=scenario.pile.alone(str(part), mesh_scale))
