"""A scripted sculptor that works towards a target shape, for the sculpting scenarios (issue 53).

The thesis's users sculpted "with the ideal target geometry shown", deforming the part until it
was an adequate representation of it (ch. 3.4 and 4.4). This module does the same with the draw
brush: each dab goes where the mesh is farthest from the target, as deep as that distance, with
brushes from broad to fine. The intent of a scenario is then the target's own parameters.

A target is a signed distance function of points, (n, 3) -> (n,), positive outside the target solid
(exact on the surface, as the CSG of a box with a sphere or a cylinder gives it near the surface).
"""

from __future__ import annotations

import numpy as np

DRAW_SPACING = 0.2  # the sculptor's dab spacing (Sculptor.stroke's default), as a share of the radius


def box(size):
    """The box [0, size] (3,)."""
    size = np.asarray(size, float)

    def distance(p):
        q = np.abs(p - size / 2) - size / 2
        return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)
    return distance


def dome(size, centre, radius):
    """The box with a sphere (centre below the top face, so that a cap stands on it) added."""
    solid, centre = box(size), np.asarray(centre, float)
    return lambda p: np.minimum(solid(p), np.linalg.norm(p - centre, axis=1) - radius)


def groove(size, y, z, radius):
    """The box less a cylinder along x through (y, z): a groove across the whole top."""
    solid = box(size)
    return lambda p: np.maximum(solid(p), radius - np.linalg.norm(p[:, 1:] - [y, z], axis=1))


def round_edge(size, radius):
    """The box with its edge along x at y = 0, z = size[2] rounded to `radius` (tangent to both faces)."""
    solid, size = box(size), np.asarray(size, float)

    def distance(p):
        d = solid(p)
        corner = (p[:, 1] < radius) & (p[:, 2] > size[2] - radius)
        q = p[corner]
        arc = np.linalg.norm(q[:, 1:] - [radius, size[2] - radius], axis=1) - radius
        d[corner] = np.maximum(arc, np.maximum(-q[:, 0], q[:, 0] - size[0]))
        return d
    return distance


def sculpt_towards(sculptor, target, radii, stop, budget):
    """Draw dabs on `sculptor` (an idealize.sculpt.Sculptor) towards `target` until every vertex is
    within `stop` of it: for each brush radius in `radii` (broad to fine), up to `budget` dabs, each
    at the vertex farthest from the target, raising or lowering it by that distance (the draw brush
    moves the dab's centre by strength x spacing x radius, strength at most 1).

    Returns (dabs, the largest and the RMS distance to the target of the vertices of the faces the
    dabs changed)."""
    dabs = 0
    for radius in radii:
        for _ in range(budget):
            points = sculptor.mesh().vertices
            error = target(points)
            k = int(np.argmax(np.abs(error)))
            if abs(error[k]) <= stop:
                break
            strength = float(np.clip(-error[k] / (DRAW_SPACING * radius), -1.0, 1.0))
            sculptor.stroke("draw", [points[k]], None, radius=radius, strength=strength, spacing=DRAW_SPACING)
            dabs += 1
    mesh = sculptor.mesh()
    error = np.abs(target(mesh.vertices[np.unique(mesh.faces[sculptor.modified()])]))
    if not len(error):
        return dabs, 0.0, 0.0
    return dabs, float(error.max()), float(np.sqrt(np.mean(error ** 2)))
