"""The built-in bent-wire parts: one skeleton each, sized like real steel wire parts.

Sizes are in millimetres here for readability. Every hook and ring leaves an opening wider
than its own wire, so a neighbour's wire can slip in and the parts can tangle. To add a part,
add one entry to `_CATALOG` (and a colour): nothing else needs to change.
"""

from __future__ import annotations

from tangle_drake.parts.wire import Arc, Line, WireSpec

MM = 1e-3

_CATALOG: dict[str, tuple[WireSpec, tuple[float, float, float, float]]] = {
    # Two 50 mm legs on a 28 mm (centre-line) bend: 70 x 34 mm, 6 mm wire, 33 g.
    "u_hook": (
        WireSpec(6 * MM, (Line(50 * MM), Arc(14 * MM, 180), Line(50 * MM))),
        (0.80, 0.55, 0.15, 1.0),
    ),
    # Hooks curled 210 degrees in opposite senses on a 36 mm shank: 77 x 38 mm, 7 mm wire, 41 g.
    "s_hook": (
        WireSpec(7 * MM, (Arc(13 * MM, 210), Line(36 * MM), Arc(13 * MM, -210))),
        (0.55, 0.60, 0.65, 1.0),
    ),
    # Split ring, 40 mm centre-line diameter, 70 degree gap: 48 mm across, 8 mm wire, 42 g.
    "c_ring": (
        WireSpec(8 * MM, (Arc(20 * MM, 290),)),
        (0.20, 0.45, 0.80, 1.0),
    ),
    # J-bolt: 80 mm shank, 32 mm bend, 22 mm return: 106 x 42 mm, 10 mm wire, 98 g.
    "j_hook": (
        WireSpec(10 * MM, (Line(80 * MM), Arc(16 * MM, 180), Line(22 * MM))),
        (0.25, 0.65, 0.30, 1.0),
    ),
    # Spine, three 40 mm prongs 25 mm apart, the middle a hairpin: 56 x 46 mm, 6 mm wire, 45 g.
    "e_shape": (
        WireSpec(
            6 * MM,
            (
                Line(36 * MM), Arc(4 * MM, 90), Line(12 * MM), Arc(4 * MM, 90),
                Line(31 * MM), Arc(5 * MM, -180), Line(31 * MM),
                Arc(4 * MM, 90), Line(12 * MM), Arc(4 * MM, 90), Line(36 * MM),
            ),
        ),
        (0.75, 0.20, 0.25, 1.0),
    ),
}

BUILTIN_PARTS: tuple[str, ...] = tuple(_CATALOG)


def builtin_spec(name: str) -> WireSpec:
    """The skeleton of built-in part `name` (a key of `BUILTIN_PARTS`)."""
    return _CATALOG[name][0]


def builtin_color(name: str) -> tuple[float, float, float, float]:
    """RGBA colour of built-in part `name`, so part types differ in a rendered pile."""
    return _CATALOG[name][1]
