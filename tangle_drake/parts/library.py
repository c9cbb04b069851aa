"""`load_part`: a built-in wire part or a user's mesh file as a cached, Drake-ready SDF model."""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.parts import build, cache, mesh_import, wire
from tangle_drake.parts.catalog import BUILTIN_PARTS, builtin_color, builtin_spec

log = logging.getLogger(__name__)

STEEL_DENSITY = 7850.0  # kg/m^3
MESH_PART_COLOR = (0.62, 0.62, 0.66, 1.0)
# Plausible part sizes (largest bounding-box side after scaling, metres).
MIN_SIZE = 1e-3
MAX_SIZE = 1.0


@dataclass(frozen=True)
class PartModel:
    """A part's generated model. The body origin is the centre of mass (so `com` is zero);
    the axes are those of the skeleton (wire parts lie in the x-y plane) or of the mesh file.
    """

    name: str  # "u_hook", or the mesh file's stem
    sdf_path: Path  # self-contained SDFormat file in the cache (mesh URIs relative to it)
    body_name: str  # "body"; the SDF's model name is `name`
    mass: float  # kg
    com: np.ndarray  # centre of mass in the body frame (3,)
    inertia: np.ndarray  # 3x3 rotational inertia about the COM, body frame
    bounding_radius: float  # radius of a sphere about the body origin enclosing the part, m
    num_collision_pieces: int
    visual_mesh_path: Path  # the one merged OBJ (with normals)


def load_part(
    part: str | os.PathLike[str], mesh_scale: float = 1.0, density: float | None = None
) -> PartModel:
    """A built-in name from BUILTIN_PARTS, a path to an .obj/.stl/.ply mesh (with its scale),
    or a part file (:data:`PART_FILE_SUFFIX`: a mesh with its scale and weighed mass).

    `mesh_scale` converts the mesh file's units to metres (0.001 for millimetres); for a
    built-in part it scales the whole part, wire included. `density` defaults to steel.
    Files are generated once per distinct input and then read from the cache.

    Meshes that are not watertight are repaired: normals fixed, then each hole closed with a
    flat triangle fan (exact for holes that are flat, like a missing end face). One that is
    still not watertight (edges shared by three faces, say) has no volume to integrate: its
    mass properties then come from a voxel fill of the solid it bounds at `density` (within
    about 2 %), or, if that finds no inside, from its convex collision pieces (up
    to a third too heavy for a bent wire); never from its convex hull, which would weigh a
    bent wire several times its mass. Either repair logs
    a warning, once per process; CoACD may also take much longer (up to minutes) on such a mesh.
    """
    scale = _positive("mesh_scale", mesh_scale)
    rho = STEEL_DENSITY if density is None else _positive("density", density)
    if str(part) in BUILTIN_PARTS:
        return _load_builtin(str(part), scale, rho)
    if Path(part).suffix.lower() == PART_FILE_SUFFIX:
        return _load_part_file(Path(part), scale)
    return _load_mesh_file(Path(part), scale, rho)


PART_FILE_SUFFIX = ".json"
"""A part file: ``{"mesh": PATH, "mesh_scale": S, "mass_kg": M}`` (``mesh`` relative to the
file; ``mass_kg`` optional), which ``tangle-drake teach`` writes: one place for the mesh, its
units and a mass the user weighed, which every command then takes as the part."""


def read_part_file(path: Path) -> tuple[Path, float, float | None]:
    """The mesh path, scale and mass (``None``: from the mesh) of a part file."""
    try:
        info = json.loads(path.read_text())
    except FileNotFoundError as error:
        raise TangleDrakeError(f"part file not found: {path}") from error
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise TangleDrakeError(f"part file {path} is unreadable: {error}") from error
    if not isinstance(info, dict) or not isinstance(info.get("mesh"), str):
        raise TangleDrakeError(f"part file {path} needs a \"mesh\" path (and may give "
                               "\"mesh_scale\" and \"mass_kg\")")
    unknown = sorted(set(info) - {"mesh", "mesh_scale", "mass_kg"})
    if unknown:
        raise TangleDrakeError(f"part file {path}: unknown field {unknown[0]!r}")
    mesh = Path(info["mesh"])
    mesh = mesh if mesh.is_absolute() else path.parent / mesh
    scale = _positive(f"{path}: mesh_scale", info.get("mesh_scale", 1.0))
    mass = info.get("mass_kg")
    return mesh, scale, None if mass is None else _positive(f"{path}: mass_kg", mass)


def part_digest(part: str | os.PathLike[str]) -> str | None:
    """SHA-256 of what a user's part is made of (the mesh file; a part file and its mesh), so
    a dataset or a benchmark is bound to its content; ``None`` for a built-in part."""
    if str(part) in BUILTIN_PARTS:
        return None
    path = Path(part)
    digest = hashlib.sha256(path.read_bytes())
    if path.suffix.lower() == PART_FILE_SUFFIX:
        digest.update(read_part_file(path)[0].read_bytes())
    return digest.hexdigest()


def _load_part_file(path: Path, scale: float) -> PartModel:
    if scale != 1.0:
        raise TangleDrakeError(f"{path} is a part file, which sets its own mesh_scale; drop "
                               "--mesh-scale")
    mesh, mesh_scale, mass = read_part_file(path)
    if mesh.suffix.lower() not in mesh_import.MESH_SUFFIXES:
        raise TangleDrakeError(f"part file {path}: its mesh must be an .obj, .stl or .ply "
                               f"file, not {mesh}")
    density = STEEL_DENSITY
    if mass is not None:  # the solid's volume, from the mesh at steel, sets the density
        density *= mass / _load_mesh_file(mesh, mesh_scale, STEEL_DENSITY).mass
    return _load_mesh_file(mesh, mesh_scale, density)


def _positive(what: str, value: Any) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if isinstance(value, bool) or not math.isfinite(number) or number <= 0.0:
        raise TangleDrakeError(f"{what} must be a positive number, got {value!r}")
    return number


def _check_size(what: str, size: float, scale: float) -> None:
    if not MIN_SIZE <= size <= MAX_SIZE:
        raise TangleDrakeError(
            f"{what} is {size:.4g} m across after scaling by mesh_scale={scale:g}; parts must "
            f"be {MIN_SIZE * 1e3:g} mm to {MAX_SIZE:g} m, so the scale is probably wrong "
            "(mesh_scale converts the file's units to metres: 0.001 for millimetres)"
        )


def _load_builtin(name: str, scale: float, density: float) -> PartModel:
    spec = builtin_spec(name).scaled(scale)
    extent = float(np.ptp(wire.centre_line(spec), axis=0).max()) + spec.wire_diameter
    _check_size(f"part {name!r}", extent, scale)
    color = builtin_color(name)
    key = cache.entry_key(
        {"kind": "wire", "name": name, "spec": repr(spec), "color": color, "density": density}
    )
    entry, meta = cache.get_or_build(
        key, lambda d: build.build_wire_part(d, name, spec, color, density)
    )
    return _model(entry, meta)


def _load_mesh_file(path: Path, scale: float, density: float) -> PartModel:
    suffix = path.suffix.lower()
    if suffix not in mesh_import.MESH_SUFFIXES:
        if not suffix and not path.exists():
            raise TangleDrakeError(
                f"unknown part {str(path)!r}: give a built-in part ({', '.join(BUILTIN_PARTS)}) "
                "or a path to an .obj, .stl or .ply mesh file"
            )
        raise TangleDrakeError(
            f"unsupported mesh format {path.suffix!r} for {path}: give an .obj, .stl or .ply file"
        )
    if not path.is_file():
        raise TangleDrakeError(f"mesh file not found: {path}")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise TangleDrakeError(f"cannot read mesh file {path}: {exc.strerror}") from exc
    if not data.strip():
        raise TangleDrakeError(f"mesh file {path} is empty")
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", path.stem) or "part"
    key = cache.entry_key(
        {
            "kind": "mesh",
            "name": name,
            "suffix": suffix,
            "sha256": hashlib.sha256(data).hexdigest(),
            "scale": scale,
            "density": density,
            "coacd": mesh_import.COACD_PARAMS,
        }
    )

    def generate(directory: Path) -> dict[str, Any]:
        mesh, holes = mesh_import.read_mesh(data, suffix, path, scale)
        _check_size(f"mesh file {path}", float(np.max(mesh.extents)), scale)
        pieces = mesh_import.convex_pieces(mesh, path)
        return build.build_mesh_part(
            directory, name, mesh, pieces, MESH_PART_COLOR, density, holes
        )

    entry, meta = cache.get_or_build(key, generate)
    if key not in _WARNED:  # a command loads its part several times: say it once
        _WARNED.add(key)
        _warn_about_repairs(path, meta)
    return _model(entry, meta)


_WARNED: set[str] = set()
"""Cache keys of the meshes whose repairs this process has warned about."""


def _warn_about_repairs(path: Path, meta: dict[str, Any]) -> None:
    if meta["holes_capped"] and meta["mass_from"] == build.MASS_FROM_MESH:
        log.warning(
            "mesh file %s had %d holes; closed them with flat triangle fans, so its mass "
            "(%.4g kg) assumes flat patches there; give a closed mesh for exact values",
            path,
            meta["holes_capped"],
            meta["mass"],
        )
    approximation = {build.MASS_FROM_VOXELS: "a voxel fill of the solid it bounds (within "
                                             "about 2 %)",
                     build.MASS_FROM_PIECES: "its convex collision pieces (which can be up to "
                                             "a third too heavy for a thin part)"}
    if meta["mass_from"] in approximation:
        log.warning(
            "mesh file %s is not watertight even after repair (holes filled, normals fixed): "
            "its mass (%.4g kg) and inertia come from %s; give a closed mesh for exact values",
            path,
            meta["mass"],
            approximation[meta["mass_from"]],
        )


def _model(entry: Path, meta: dict[str, Any]) -> PartModel:
    return PartModel(
        name=meta["name"],
        sdf_path=entry / meta["sdf"],
        body_name=meta["body_name"],
        mass=float(meta["mass"]),
        com=np.asarray(meta["com"], dtype=float),
        inertia=np.asarray(meta["inertia"], dtype=float),
        bounding_radius=float(meta["bounding_radius"]),
        num_collision_pieces=int(meta["num_collision_pieces"]),
        visual_mesh_path=entry / meta["visual"],
    )
