"""Bent-wire parts from a planar skeleton: capsules for contact, one swept tube for the eye.

A skeleton is a chain of straight lines and circular arcs drawn like a turtle in the body
x-y plane: it starts at the origin heading along +x, a `Line` moves ahead and an `Arc` turns
while moving (positive angle = left, counter-clockwise seen from +z). Chaining tangent pieces
keeps the centre line smooth, so the swept tube never folds onto itself at a corner.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import trimesh

# Sides of the tube's polygonal cross-section and the largest turn between two rings of it.
TUBE_SIDES = 24
_TUBE_STEP_DEG = 7.5
# Latitude rings of each hemispherical end cap (the ends match the capsules' round ends).
_CAP_RINGS = 6
# A capsule replaces an arc's chord; the chord may stray from the arc by at most this
# fraction of the wire diameter. 0.2 keeps 6-16 capsules per part and the contact shape
# within 0.7-1.4 mm of the drawn tube on the built-in parts.
CHORD_SAGITTA_PER_DIAMETER = 0.2


@dataclass(frozen=True)
class Line:
    """Straight wire of `length` metres along the current heading."""

    length: float


@dataclass(frozen=True)
class Arc:
    """Bend of centre-line `radius` (m) through `angle_deg` (+ left, - right)."""

    radius: float
    angle_deg: float


Segment = Line | Arc


@dataclass(frozen=True)
class WireSpec:
    """Everything that defines a wire part's geometry (this is what the cache key hashes)."""

    wire_diameter: float
    skeleton: tuple[Segment, ...]

    def scaled(self, factor: float) -> WireSpec:
        """The same part `factor` times larger (wire included)."""
        return WireSpec(
            wire_diameter=self.wire_diameter * factor,
            skeleton=tuple(
                Line(s.length * factor)
                if isinstance(s, Line)
                else Arc(s.radius * factor, s.angle_deg)
                for s in self.skeleton
            ),
        )


@dataclass(frozen=True)
class CapsuleSpec:
    """A capsule between two points of the centre line (body frame, metres)."""

    start: np.ndarray
    end: np.ndarray
    radius: float


def _left(heading: float) -> np.ndarray:
    """Unit vector 90 degrees left of `heading` in the x-y plane."""
    return np.array([-math.sin(heading), math.cos(heading), 0.0])


def _ahead(heading: float) -> np.ndarray:
    return np.array([math.cos(heading), math.sin(heading), 0.0])


def _walk(spec: WireSpec, arc_pieces: Callable[[Arc], int]) -> list[tuple[np.ndarray, float]]:
    """Points (with headings) along the skeleton; `arc_pieces(arc)` says how finely to cut arcs.

    Lines contribute only their end point: a straight stretch needs nothing in between.
    """
    position = np.zeros(3)
    heading = 0.0
    points = [(position, heading)]
    for segment in spec.skeleton:
        if isinstance(segment, Line):
            position = position + segment.length * _ahead(heading)
            points.append((position, heading))
            continue
        turn = math.radians(segment.angle_deg)
        side = math.copysign(1.0, turn)
        centre = position + side * segment.radius * _left(heading)
        pieces = arc_pieces(segment)
        for k in range(1, pieces + 1):
            h = heading + turn * k / pieces
            points.append((centre - side * segment.radius * _left(h), h))
        position, heading = points[-1]
    return points


def _chord_pieces(spec: WireSpec) -> Callable[[Arc], int]:
    """How many capsules an arc needs so each chord stays within the sagitta tolerance."""
    sagitta = CHORD_SAGITTA_PER_DIAMETER * spec.wire_diameter

    def pieces(arc: Arc) -> int:
        if sagitta >= arc.radius:
            return 1
        max_chord_angle = 2.0 * math.acos(1.0 - sagitta / arc.radius)
        return max(1, math.ceil(math.radians(abs(arc.angle_deg)) / max_chord_angle - 1e-9))

    return pieces


def centre_line(spec: WireSpec) -> np.ndarray:
    """The skeleton's vertices as the capsules see it, shape (n, 3)."""
    return np.array([p for p, _ in _walk(spec, _chord_pieces(spec))])


def capsules(spec: WireSpec) -> list[CapsuleSpec]:
    """One capsule per line, a few per arc (see `CHORD_SAGITTA_PER_DIAMETER`)."""
    points = centre_line(spec)
    radius = spec.wire_diameter / 2.0
    return [CapsuleSpec(a, b, radius) for a, b in itertools.pairwise(points)]


def tube_mesh(spec: WireSpec) -> trimesh.Trimesh:
    """A watertight tube swept along the skeleton, with hemispherical ends.

    The polygon's radius is enlarged so its area equals the round wire's: the mesh's volume
    (hence the mass computed from it) is that of the real wire, not of a 24-gon prism.
    """
    n = TUBE_SIDES
    radius = spec.wire_diameter / 2.0 * math.sqrt(2.0 * math.pi / (n * math.sin(2.0 * math.pi / n)))
    samples = _walk(spec, lambda arc: max(1, math.ceil(abs(arc.angle_deg) / _TUBE_STEP_DEG)))
    phi = 2.0 * math.pi * np.arange(n) / n
    z = np.array([0.0, 0.0, 1.0])

    def ring(centre: np.ndarray, heading: float, r: float) -> np.ndarray:
        return centre + r * (np.outer(np.cos(phi), _left(heading)) + np.outer(np.sin(phi), z))

    lat = np.linspace(0.0, math.pi / 2.0, _CAP_RINGS + 1)[:-1]  # excludes the pole
    (p0, h0), (p1, h1) = samples[0], samples[-1]
    start_cap = [
        ring(p0 - radius * math.sin(a) * _ahead(h0), h0, radius * math.cos(a)) for a in lat[::-1]
    ]
    end_cap = [ring(p1 + radius * math.sin(a) * _ahead(h1), h1, radius * math.cos(a)) for a in lat]
    body = [ring(p, h, radius) for p, h in samples[1:-1]]
    rings = [*start_cap, *body, *end_cap]  # start_cap ends and end_cap begins with a full ring

    vertices = np.vstack([p0 - radius * _ahead(h0), *rings, p1 + radius * _ahead(h1)])
    last_pole = len(vertices) - 1
    j = np.arange(n)
    jn = (j + 1) % n
    faces = [np.column_stack([np.zeros(n, dtype=int), 1 + jn, 1 + j])]
    for i in range(len(rings) - 1):
        a, b = 1 + i * n + j, 1 + i * n + jn
        c, d = b + n, a + n
        faces += [np.column_stack([a, b, c]), np.column_stack([a, c, d])]
    base = 1 + (len(rings) - 1) * n
    faces.append(np.column_stack([base + j, base + jn, np.full(n, last_pole)]))
    return trimesh.Trimesh(vertices=vertices, faces=np.vstack(faces), process=False)


def wire_length(spec: WireSpec) -> float:
    """Length of the centre line (m)."""
    return sum(
        s.length if isinstance(s, Line) else s.radius * math.radians(abs(s.angle_deg))
        for s in spec.skeleton
    )
