"""The part library: built-in wire parts and mesh files become valid, cached Drake models."""

import itertools
import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from pydrake.geometry import Capsule, Convex
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.multibody.tree import RotationalInertia, SpatialInertia
from pydrake.systems.framework import DiagramBuilder

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.parts import (
    BUILTIN_PARTS,
    PartModel,
    catalog,
    library,
    load_part,
    mesh_import,
    wire,
)
from tangle_drake.parts import build as part_build

STEEL = 7850.0


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch) -> Path:
    """A fresh, private cache for every test."""
    root = tmp_path / "cache"
    monkeypatch.setenv("TANGLE_DRAKE_CACHE", str(root))
    return root


def _u_tube_mm() -> trimesh.Trimesh:
    """A non-convex part (the U-hook's tube) in millimetres, as a user's CAD file would be."""
    mesh = wire.tube_mesh(catalog.builtin_spec("u_hook"))
    mesh.apply_scale(1000.0)
    return mesh


@pytest.fixture
def u_stl(tmp_path) -> Path:
    path = tmp_path / "u_bracket.stl"
    _u_tube_mm().export(path)
    return path


def _load_in_drake(part: PartModel, caplog):
    """Parse the part strictly (warnings are errors) and check Drake logged no warning."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    parser = Parser(plant)
    parser.SetStrictParsing()
    with caplog.at_level(logging.WARNING, logger="drake"):
        (model,) = parser.AddModels(str(part.sdf_path))
        plant.Finalize()
    assert not [r for r in caplog.records if r.name.startswith("drake")]
    assert plant.GetModelInstanceName(model) == part.name
    body = plant.GetBodyByName(part.body_name, model)
    geometries = plant.GetCollisionGeometriesForBody(body)
    return body, scene_graph.model_inspector(), geometries


def _files(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


@pytest.mark.parametrize("name", BUILTIN_PARTS)
def test_builtin_part_is_a_valid_drake_model(name, caplog):
    part = load_part(name)
    spec = catalog.builtin_spec(name)
    radius = spec.wire_diameter / 2
    # Mass from the tube mesh matches a round wire of that length with round ends.
    expected = STEEL * (math.pi * radius**2 * wire.wire_length(spec) + 4 / 3 * math.pi * radius**3)
    assert part.mass == pytest.approx(expected, rel=0.01)
    assert np.allclose(part.com, 0.0)
    i = part.inertia
    rotational = RotationalInertia(i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2])
    assert rotational.CouldBePhysicallyValid()
    spatial = SpatialInertia.MakeFromCentralInertia(part.mass, part.com, rotational)
    assert spatial.IsPhysicallyValid()
    assert 6 <= part.num_collision_pieces <= 16

    visual = trimesh.load_mesh(part.visual_mesh_path)
    assert visual.is_watertight and visual.is_volume
    assert 0.040 <= max(visual.extents) <= 0.110
    assert np.allclose(visual.center_mass, 0.0, atol=1e-6)  # body origin at the COM
    assert np.linalg.norm(visual.vertices, axis=1).max() <= part.bounding_radius
    assert part.bounding_radius <= max(visual.extents)
    lines = part.visual_mesh_path.read_text().splitlines()
    assert sum(x.startswith("vn ") for x in lines) == sum(x.startswith("v ") for x in lines) > 0

    body, inspector, geometries = _load_in_drake(part, caplog)
    assert len(geometries) == part.num_collision_pieces
    assert all(isinstance(inspector.GetShape(g), Capsule) for g in geometries)
    assert body.default_mass() == pytest.approx(part.mass)
    # The capsules form one chain along the skeleton: each starts where the last one ended
    # (this checks the SDF poses turn Drake's capsule axis, +z, the right way).
    ends = []
    for g in sorted(geometries, key=inspector.GetName):
        pose, length = inspector.GetPoseInFrame(g), inspector.GetShape(g).length()
        ends.append([pose @ np.array([0.0, 0.0, s * length / 2]) for s in (-1, 1)])
    for (_, end), (start, _) in itertools.pairwise(ends):
        assert np.allclose(end, start, atol=1e-7)


@pytest.mark.parametrize("name", BUILTIN_PARTS)
def test_builtin_openings_let_another_wire_in(name):
    """Near each free end the wire leaves a gap wider than the wire, so parts can tangle."""
    spec = catalog.builtin_spec(name)
    points = np.array([p for p, _ in wire._walk(spec, lambda arc: math.ceil(abs(arc.angle_deg)))])
    along = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    d = spec.wire_diameter
    for tip, from_tip in ((points[0], along), (points[-1], along[-1] - along)):
        far = from_tip > 3 * d
        clearance = np.linalg.norm(points[far] - tip, axis=1).min() - d
        assert clearance >= d


def test_builtin_parts_differ_in_size():
    sizes = {name: load_part(name).bounding_radius for name in BUILTIN_PARTS}
    assert len({round(r, 4) for r in sizes.values()}) == len(BUILTIN_PARTS)


def test_scale_and_density_make_new_entries():
    base = load_part("u_hook")
    light = load_part("u_hook", density=2700.0)
    small = load_part("u_hook", mesh_scale=0.8)
    assert light.sdf_path != base.sdf_path
    assert light.mass == pytest.approx(base.mass * 2700.0 / STEEL)
    assert small.mass == pytest.approx(base.mass * 0.8**3, rel=1e-6)
    assert small.bounding_radius == pytest.approx(base.bounding_radius * 0.8, abs=2e-6)


def test_builtin_cache_is_hit_and_files_are_deterministic(cache, monkeypatch, tmp_path):
    first = load_part("e_shape")
    entry = first.sdf_path.parent
    mtimes = {p: p.stat().st_mtime_ns for p in entry.iterdir()}

    def no_build(*args, **kwargs):
        raise AssertionError("the cache should have been used")

    monkeypatch.setattr(part_build, "build_wire_part", no_build)
    again = load_part("e_shape")
    assert again.sdf_path == first.sdf_path and again.mass == first.mass
    assert {p: p.stat().st_mtime_ns for p in entry.iterdir()} == mtimes
    monkeypatch.undo()

    monkeypatch.setenv("TANGLE_DRAKE_CACHE", str(tmp_path / "other_cache"))
    fresh = load_part("e_shape")
    assert fresh.sdf_path != first.sdf_path
    assert _files(fresh.sdf_path.parent) == _files(entry)


def test_failed_build_leaves_no_entry(cache, monkeypatch):
    def broken_sdf(path, *args, **kwargs):
        path.write_text("<sdf")  # half-written, then the run dies
        raise KeyboardInterrupt

    monkeypatch.setattr(part_build, "write_part_sdf", broken_sdf)
    with pytest.raises(KeyboardInterrupt):
        load_part("c_ring")
    assert list((cache / "parts").iterdir()) == []
    monkeypatch.undo()
    assert load_part("c_ring").mass > 0


def test_nonconvex_mesh_gives_convex_pieces(u_stl, monkeypatch, caplog, tmp_path):
    part = load_part(u_stl, mesh_scale=0.001)
    assert part.name == "u_bracket"
    assert part.num_collision_pieces >= 3  # a U cannot be one convex piece
    assert part.mass == pytest.approx(load_part("u_hook").mass, rel=1e-3)
    assert np.allclose(part.com, 0.0)
    assert 0.030 <= part.bounding_radius <= 0.045
    body, inspector, geometries = _load_in_drake(part, caplog)
    assert len(geometries) == part.num_collision_pieces
    assert all(isinstance(inspector.GetShape(g), Convex) for g in geometries)
    assert body.default_mass() == pytest.approx(part.mass)
    assert "\nvn " in part.visual_mesh_path.read_text()

    # Second load: read from the cache, CoACD never runs and no file is rewritten.
    entry = part.sdf_path.parent
    mtimes = {p: p.stat().st_mtime_ns for p in entry.iterdir()}

    def no_coacd(*args, **kwargs):
        raise AssertionError("CoACD should not run on a cache hit")

    monkeypatch.setattr(mesh_import.coacd, "run_coacd", no_coacd)
    assert load_part(u_stl, mesh_scale=0.001).sdf_path == part.sdf_path
    assert {p: p.stat().st_mtime_ns for p in entry.iterdir()} == mtimes
    monkeypatch.undo()

    # Same inputs in another cache: byte-identical files (CoACD is seeded).
    monkeypatch.setenv("TANGLE_DRAKE_CACHE", str(tmp_path / "other_cache"))
    assert _files(load_part(u_stl, mesh_scale=0.001).sdf_path.parent) == _files(entry)


def test_mesh_with_a_hole_is_capped_with_a_warning(tmp_path, caplog, monkeypatch):
    monkeypatch.setattr(library, "_WARNED", set())
    mesh = _u_tube_mm()
    cap = np.arange(len(mesh.faces)) < wire.TUBE_SIDES * 6  # drop one round end
    mesh.update_faces(~cap)
    mesh.remove_unreferenced_vertices()
    assert not mesh.is_watertight
    path = tmp_path / "open_end.obj"
    mesh.export(path)
    with caplog.at_level(logging.WARNING, logger="tangle_drake"):
        part = load_part(path, mesh_scale=0.001)
    assert "holes" in caplog.text and "open_end.obj" in caplog.text
    # A flat patch replaces the missing round end: a little lighter than the closed part.
    assert part.mass == pytest.approx(load_part("u_hook").mass, rel=0.02)
    _load_in_drake(part, caplog)


def _with_a_fin(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """``mesh`` with an extra face on one edge: three faces share it, no repair closes it."""
    a, b = mesh.faces[0][:2]
    return trimesh.Trimesh(np.vstack([mesh.vertices, mesh.vertices[a] + [0.0, 0.0, 1.0]]),
                           np.vstack([mesh.faces, [[a, b, len(mesh.vertices)]]]), process=False)


def test_mesh_that_stays_open_weighs_a_voxel_fill(tmp_path, caplog, monkeypatch):
    monkeypatch.setattr(library, "_WARNED", set())
    path = tmp_path / "finned.ply"
    _with_a_fin(trimesh.creation.box(extents=(40.0, 20.0, 10.0))).export(path)
    with caplog.at_level(logging.WARNING, logger="tangle_drake"):
        part = load_part(path, mesh_scale=0.001)
    assert "voxel fill" in caplog.text
    assert part.mass == pytest.approx(STEEL * 40e-3 * 20e-3 * 10e-3, rel=0.02)
    _load_in_drake(part, caplog)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="tangle_drake"):
        load_part(path, mesh_scale=0.001)  # again in this process: said once is enough
    assert "voxel fill" not in caplog.text
    monkeypatch.setattr(library, "_WARNED", set())  # as in a new process
    with caplog.at_level(logging.WARNING, logger="tangle_drake"):
        load_part(path, mesh_scale=0.001)  # from the cache: still warned
    assert "voxel fill" in caplog.text


def test_an_open_bent_wire_weighs_about_its_wire_not_its_hull(tmp_path, monkeypatch):
    monkeypatch.setattr(library, "_WARNED", set())
    tube = _u_tube_mm()
    path = tmp_path / "open_hook.stl"
    _with_a_fin(tube).export(path)
    part = load_part(path, mesh_scale=0.001)
    wire_mass = load_part("u_hook").mass
    hull_mass = STEEL * tube.convex_hull.volume * 1e-9
    assert hull_mass > 3 * wire_mass  # what the hull would have said
    assert part.mass == pytest.approx(wire_mass, rel=0.02)
    reference = load_part("u_hook").inertia
    assert np.allclose(part.inertia, reference, rtol=0.05, atol=0.05 * np.abs(reference).max())


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply"])
def test_garbage_file_is_a_clear_error(tmp_path, suffix):
    path = tmp_path / f"garbage{suffix}"
    path.write_bytes(np.random.default_rng(0).bytes(3000))
    with pytest.raises(TangleDrakeError, match="garbage"):
        load_part(path)


@pytest.mark.parametrize(
    ("content", "match"),
    [(b"", "empty"), (b"# just a comment\nhello world\n", "no triangles")],
)
def test_empty_mesh_is_a_clear_error(tmp_path, content, match):
    path = tmp_path / "empty.obj"
    path.write_bytes(content)
    with pytest.raises(TangleDrakeError, match=match):
        load_part(path)


def test_missing_file_unknown_name_and_bad_extension(tmp_path):
    with pytest.raises(TangleDrakeError, match="not found"):
        load_part(tmp_path / "nowhere.stl")
    with pytest.raises(TangleDrakeError, match="u_hook"):
        load_part("w_hook")  # not a built-in, not a file: the error lists the built-ins
    collada = tmp_path / "part.dae"
    collada.write_text("<COLLADA/>")
    with pytest.raises(TangleDrakeError, match=r"\.obj, \.stl or \.ply"):
        load_part(collada)


@pytest.mark.parametrize("scale", [0.0, -0.001, float("nan"), float("inf"), "big", True])
def test_bad_scale_is_a_clear_error(u_stl, scale):
    with pytest.raises(TangleDrakeError, match="mesh_scale"):
        load_part(u_stl, mesh_scale=scale)
    with pytest.raises(TangleDrakeError, match="mesh_scale"):
        load_part("s_hook", mesh_scale=scale)


@pytest.mark.parametrize("density", [0.0, -7850.0, float("nan")])
def test_bad_density_is_a_clear_error(density):
    with pytest.raises(TangleDrakeError, match="density"):
        load_part("j_hook", density=density)


@pytest.mark.parametrize(("part", "scale"), [("u_stl", 1.0), ("u_stl", 1e-6), ("j_hook", 20.0)])
def test_absurd_size_says_the_scale_is_wrong(request, part, scale):
    target = request.getfixturevalue(part) if part == "u_stl" else part
    with pytest.raises(TangleDrakeError, match="scale is probably wrong"):
        load_part(target, mesh_scale=scale)


def test_a_part_file_names_its_mesh_scale_and_weighed_mass(tmp_path, u_stl):
    from tangle_drake.parts.library import part_digest

    computed = load_part(u_stl, mesh_scale=0.001)
    part_file = tmp_path / "part.json"
    part_file.write_text(json.dumps({"mesh": str(u_stl), "mesh_scale": 0.001}))
    same = load_part(part_file)
    assert same.mass == computed.mass and same.name == computed.name
    part_file.write_text(json.dumps({"mesh": u_stl.name, "mesh_scale": 0.001,
                                     "mass_kg": 0.05}))  # relative to the part file
    (tmp_path / u_stl.name).write_bytes(u_stl.read_bytes())
    weighed = load_part(part_file)
    assert weighed.mass == pytest.approx(0.05)
    assert np.allclose(weighed.inertia, computed.inertia * 0.05 / computed.mass)
    before = part_digest(part_file)
    (tmp_path / u_stl.name).write_bytes(u_stl.read_bytes() + b"\n")
    assert part_digest(part_file) != before  # bound to the mesh's content too
    with pytest.raises(TangleDrakeError, match="drop --mesh-scale"):
        load_part(part_file, mesh_scale=0.001)
    for content, message in (("{", "unreadable"), ('{"mesh_scale": 1}', "needs a"),
                             ('{"mesh": "a.stl", "colour": 1}', "unknown field 'colour'"),
                             ('{"mesh": "a.stl", "mass_kg": -1}', "mass_kg"),
                             ('{"mesh": "a.txt"}', "must be an .obj")):
        part_file.write_text(content)
        with pytest.raises(TangleDrakeError, match=message):
            load_part(part_file)
    with pytest.raises(TangleDrakeError, match="part file not found"):
        load_part(tmp_path / "missing.json")
