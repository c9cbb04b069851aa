"""The entanglement map (Zhang et al. 2021): the writhe of segment pairs and the map."""

import itertools
from types import SimpleNamespace

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.entanglement.emap import EmapParams, entanglement_map
from tangle_drake.entanglement.writhe import segment_writhe, writhe_matrix
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.selection.emap_system import EntanglementMapSystem
from tangle_drake.selection.rules import ScoredCandidate, rank_candidates


def gauss_writhe(a0, a1, b0, b1, steps: int = 800) -> float:
    """The Gauss double integral, by the midpoint rule."""
    s = (np.arange(steps) + 0.5) / steps
    a, b = a0 + np.outer(s, a1 - a0), b0 + np.outer(s, b1 - b0)
    between = a[:, None, :] - b[None, :, :]
    cross = np.cross((a1 - a0) / steps, (b1 - b0) / steps)
    return float((between @ cross / np.linalg.norm(between, axis=2) ** 3).sum() / (4 * np.pi))


def test_the_closed_form_is_the_gauss_integral():
    rng = np.random.default_rng(0)
    for _ in range(5):
        a0, a1, b0, b1 = rng.normal(size=(4, 3))
        assert segment_writhe(a0, a1, b0, b1) == pytest.approx(gauss_writhe(a0, a1, b0, b1),
                                                               abs=2e-6)
    # Two unit-length segments crossing squarely, one above the other: a quarter turn each way.
    a0, a1, b0, b1 = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0.5], [0, 1, 0.5]], float)
    assert segment_writhe(a0, a1, b0, b1) == pytest.approx(gauss_writhe(a0, a1, b0, b1),
                                                           abs=2e-6)


def test_a_mirror_flips_the_sign_and_segments_in_a_plane_give_zero():
    rng = np.random.default_rng(1)
    ends = rng.normal(size=(4, 3))
    mirror = ends * np.array([1.0, 1.0, -1.0])
    assert segment_writhe(*mirror) == pytest.approx(-segment_writhe(*ends))
    parallel = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.3], [1, 1, 0.3]], float)
    assert segment_writhe(*parallel) == pytest.approx(0.0, abs=1e-12)
    flat = ends * np.array([1.0, 1.0, 0.0])  # all four ends in one plane
    assert segment_writhe(*flat) == pytest.approx(0.0, abs=1e-12)
    assert segment_writhe(ends[0], ends[0], ends[2], ends[3]) == 0.0  # a point is no segment
    matrix = writhe_matrix(rng.normal(size=(5, 2, 3)))
    assert np.allclose(matrix, matrix.T) and np.all(np.diag(matrix) == 0)


SIZE = 400
FLOOR = 1.0  # metres from the camera


def render(curves: list[np.ndarray], radius: float = 3.5) -> np.ndarray:
    """A top view of wires along 3-D ``curves`` (pixels, pixels, height in pixels): depth in
    metres (a pixel is 1 mm), the highest wire wins."""
    height = np.zeros((SIZE, SIZE))
    rows, cols = np.mgrid[:SIZE, :SIZE]
    for curve in curves:
        dense = np.concatenate([np.linspace(p, q, 12, endpoint=False)
                                for p, q in itertools.pairwise(curve)])
        for u, v, h in dense:
            near = (cols - u) ** 2 + (rows - v) ** 2 <= radius ** 2
            top = h + radius + np.sqrt(np.clip(radius ** 2 - (cols - u) ** 2
                                               - (rows - v) ** 2, 0, None))
            height = np.where(near, np.maximum(height, top), height)
    return FLOOR - height / 1000.0


def ring(centre, radius, normal_tilt: float, turn: float, points: int = 48) -> np.ndarray:
    """A circle of ``radius`` px about ``centre`` (u, v, h), tilted by ``normal_tilt`` about
    the u axis, then turned by ``turn`` about the vertical."""
    t = np.linspace(0, 2 * np.pi, points + 1)
    circle = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1) * radius
    c, s = np.cos(normal_tilt), np.sin(normal_tilt)
    circle = circle @ np.array([[1, 0, 0], [0, c, s], [0, -s, c]])
    c, s = np.cos(turn), np.sin(turn)
    circle = circle @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    return circle + np.asarray(centre, float)


@pytest.fixture(scope="module")
def scene():
    """A lone straight wire on the left; two interlocked rings on the right."""
    wire = np.array([[60.0, 80.0, 5.0], [140.0, 320.0, 5.0]])
    first = ring((280, 200, 40), 50, 0.25, 0.0)
    second = ring((320, 200, 40), 50, np.pi / 2 - 0.2, 0.3)  # through the first one
    return render([wire, first, second])


def test_the_map_is_higher_over_the_interlock_than_over_a_lone_wire(scene):
    emap = entanglement_map(scene)
    assert len(emap.segments) >= 10
    image = emap.image()
    interlock = image[150:250, 250:350].mean()
    lone_wire = image[120:280, 60:140].mean()
    assert interlock > lone_wire + 0.3
    assert emap.at([300.0], [200.0])[0] > emap.at([100.0], [200.0])[0]
    wire = np.array([[60.0, 80.0, 5.0], [140.0, 320.0, 5.0]])
    apart = entanglement_map(render([wire, ring((280, 110, 40), 45, 0.25, 0.0),
                                     ring((300, 300, 40), 45, 0.25, 0.3)]))
    assert emap.grid.max() > 1.5 * apart.grid.max()  # the same rings, not linked: calmer


def test_the_map_does_not_depend_on_the_images_units(scene):
    metres = entanglement_map(scene)
    millimetres = entanglement_map(scene * 1000.0)
    np.testing.assert_allclose(millimetres.grid, metres.grid)
    region = entanglement_map(scene, (20, 20, 380, 380))
    mask = np.zeros(scene.shape, bool)
    mask[20:380, 20:380] = True
    np.testing.assert_allclose(entanglement_map(scene, mask).grid, region.grid)


def test_bad_inputs_are_named():
    with pytest.raises(TangleDrakeError, match="2-D"):
        entanglement_map(np.zeros(5))
    with pytest.raises(TangleDrakeError, match="no valid depth"):
        entanglement_map(np.full((50, 50), np.nan))
    with pytest.raises(TangleDrakeError, match="holds no pixels"):
        entanglement_map(np.ones((50, 50)), (60, 60, 80, 80))
    with pytest.raises(ValueError, match="window"):
        EmapParams(window=300)
    flat = entanglement_map(np.ones((120, 160)))  # nothing in the bin: no segment, all 0
    assert len(flat.segments) == 0 and not flat.grid.any()


def _system_outputs(system, depth: np.ndarray, candidates: list, cnn_scored=None):
    builder = DiagramBuilder()
    builder.AddSystem(system)
    image = ImageDepth32F(depth.shape[1], depth.shape[0])
    image.mutable_data[:, :, 0] = depth
    for port, value in (("depth_image", image), ("candidates", candidates),
                        ("cnn_scored", cnn_scored)):
        if value is not None:
            source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(value)))
            builder.Connect(source.get_output_port(), system.GetInputPort(port))
    diagram = builder.Build()
    context = system.GetMyContextFromRoot(diagram.CreateDefaultContext())
    return {name: system.GetOutputPort(name).Eval(context)
            for name in ("entanglement_map", "scored_candidates", "selected_grasp")}


def test_the_system_ranks_graspabilitys_candidates_by_low_entanglement(scene):
    candidates = [SimpleNamespace(u=u, v=200.0, angle_deg=0.0, score=s)
                  for u, s in ((300.0, 1.0), (100.0, 0.9), (200.0, 0.5))]
    intrinsics = CameraIntrinsics.from_fov_y(SIZE, SIZE, 45.0)
    out = _system_outputs(EntanglementMapSystem(intrinsics), scene.astype(np.float32),
                          candidates)
    expected = entanglement_map(scene.astype(np.float32))
    np.testing.assert_allclose(out["entanglement_map"].grid, expected.grid)
    entanglement = expected.at([c.u for c in candidates], [c.v for c in candidates])
    assert [s.candidate.u for s in out["scored_candidates"]] == [
        s.candidate.u for s in rank_candidates("emap", candidates, entanglement=entanglement)]
    assert out["scored_candidates"][0].candidate.u == 100.0  # the lone wire, not the rings
    assert out["selected_grasp"] is out["scored_candidates"][0].candidate

    fused = EntanglementMapSystem(intrinsics, rule="emap-harmonic")
    cnn = [ScoredCandidate(c, p, 0.0) for c, p in zip(candidates, (0.9, 0.2, 0.8),
                                                       strict=True)]
    scored = _system_outputs(fused, scene.astype(np.float32), candidates, cnn)
    assert [s.p_model for s in scored["scored_candidates"]] == [
        s.p_model for s in rank_candidates("emap-harmonic", candidates,
                                                 np.array([0.9, 0.2, 0.8]),
                                                 entanglement=entanglement)]
    with pytest.raises(TangleDrakeError, match="needs the tangle CNN"):
        _system_outputs(EntanglementMapSystem(intrinsics, rule="emap-harmonic"),
                        scene.astype(np.float32), candidates)
    with pytest.raises(TangleDrakeError, match="ranks by"):
        EntanglementMapSystem(intrinsics, rule="harmonic")
