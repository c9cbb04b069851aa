"""The writhe of pairs of straight segments: how much two pieces of wire wind around each other.

For segments ``a0 -> a1`` and ``b0 -> b1`` the Gauss double integral

    Wr = 1/(4 pi) * integral integral (dA x dB) . (A - B) / |A - B|^3

has a closed form (Klenin & Langowski 2000, "Computation of writhe in modeling of supercoiled
DNA", Biopolymers 54): the solid angle ``Omega`` that segment B sweeps as seen from segment A,
the sum of four arcsines of the normals of the tetrahedron the four end points span, signed by
the segments' handedness. ``Wr = Omega / (4 pi)``; it lies in (-1/2, 1/2), is 0 for segments
in one plane (parallel, crossing or apart) and changes sign in a mirror. Numpy only, every
pair at once.
"""

from __future__ import annotations

import numpy as np


def segment_writhe(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray,
                   b1: np.ndarray) -> np.ndarray:
    """The writhe of segment pairs: arrays (..., 3) of end points in, (...) out.

    Degenerate pairs (a zero-length segment, four coplanar end points) give 0.
    """
    a0, a1, b0, b1 = (np.asarray(x, dtype=np.float64) for x in (a0, a1, b0, b1))
    r13, r14, r23, r24 = b0 - a0, b1 - a0, b0 - a1, b1 - a1
    normals = [np.cross(r13, r14), np.cross(r14, r24), np.cross(r24, r23), np.cross(r23, r13)]
    lengths = [np.linalg.norm(n, axis=-1) for n in normals]
    tiny = 1e-12 * np.maximum.reduce([np.linalg.norm(r, axis=-1) for r in (r13, r24)]) ** 2
    valid = np.logical_and.reduce([length > tiny for length in lengths])
    units = [n / np.where(valid, length, 1.0)[..., None] for n, length in zip(normals, lengths,
                                                                             strict=True)]
    omega = sum(np.arcsin(np.clip(np.sum(units[k] * units[(k + 1) % 4], axis=-1), -1.0, 1.0))
                for k in range(4))
    handedness = np.sign(np.sum(np.cross(b1 - b0, a1 - a0) * r13, axis=-1))
    return np.where(valid, omega * handedness / (4.0 * np.pi), 0.0)


def writhe_matrix(segments: np.ndarray) -> np.ndarray:
    """The writhe of every pair of ``segments`` ((N, 2, 3) end points): (N, N), symmetric,
    zero on the diagonal."""
    segments = np.asarray(segments, dtype=np.float64)
    n = len(segments)
    if n < 2:
        return np.zeros((n, n))
    i, j = np.triu_indices(n, 1)
    upper = segment_writhe(segments[i, 0], segments[i, 1], segments[j, 0], segments[j, 1])
    matrix = np.zeros((n, n))
    matrix[i, j] = matrix[j, i] = upper
    return matrix
