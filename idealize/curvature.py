"""Per-vertex curvature (Meyer, Desbrun, Schröder, Barr 2003). Convex is positive."""
from ._loader import native
from .mesh import Mesh


def vertex_curvature(mesh):
    """Discrete curvature of every vertex of an idealize.Mesh.

    Returns a dict of numpy arrays: "mean" H (#V,), "gaussian" K (#V,), "kmax", "kmin" principal
    curvatures (#V,), "area" mixed Voronoi area (#V,), "normal" unit normals (#V, 3). Boundary
    vertices take the area-weighted mean of their interior neighbours.
    """
    if not isinstance(mesh, Mesh):
        raise TypeError("vertex_curvature() takes an idealize.Mesh, got %s" % type(mesh).__name__)
    return native.vertex_curvature(mesh.vertices, mesh.faces)
