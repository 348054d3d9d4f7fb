"""Discrete curvature against analytic values (Meyer et al. 2003)."""
import numpy as np

import idealize
import shapes


def test_sphere_mean_and_gaussian_curvature():
    V, F = shapes.icosphere(radius=2.0, subdivisions=4)
    c = idealize.vertex_curvature(idealize.Mesh(V, F))
    assert np.allclose(c["mean"], 0.5, rtol=0.01)          # H = 1/r, convex positive
    assert np.allclose(c["gaussian"], 0.25, rtol=0.03)     # K = 1/r²
    assert np.allclose(c["kmax"], 0.5, atol=0.02) and np.allclose(c["kmin"], 0.5, atol=0.02)
    assert np.allclose(c["area"].sum(), 4 * np.pi * 4, rtol=0.01)


def test_inward_sphere_is_concave():
    V, F = shapes.icosphere(radius=2.0, subdivisions=3)
    c = idealize.vertex_curvature(idealize.Mesh(V, F[:, ::-1]))
    assert np.allclose(c["mean"], -0.5, rtol=0.02)


def test_cylinder_mean_curvature_is_half_inverse_radius():
    V, F = shapes.tube(radius=3.0, length=10.0, segments=96, rings=60)
    c = idealize.vertex_curvature(idealize.Mesh(V, F))
    interior = (V[:, 2] > 1.0) & (V[:, 2] < 9.0)
    assert np.allclose(c["mean"][interior], 1 / 6, rtol=0.02)
    assert np.allclose(c["gaussian"][interior], 0.0, atol=2e-3)
    assert np.allclose(c["kmax"][interior], 1 / 3, rtol=0.03)
    assert np.allclose(c["kmin"][interior], 0.0, atol=0.01)


def test_plane_has_zero_curvature_for_any_triangulation():
    V, F = shapes.grid(n=20)
    c = idealize.vertex_curvature(idealize.Mesh(V, F))
    assert np.abs(c["mean"]).max() < 1e-9
    assert np.abs(c["gaussian"]).max() < 1e-9
    assert np.allclose(np.abs(c["normal"][:, 2]), 1.0)
