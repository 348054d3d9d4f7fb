"""Triangle meshes as numpy arrays: vertices float64 (N, 3), faces int32 (M, 3), row-major."""
import os

import numpy as np

from ._loader import native

MeshError = native.MeshError
MeshError.__doc__ = "The mesh cannot be used; the message says why."

# Peak memory of a whole conversion per input triangle: 650 bytes measured on a 5.49M-triangle scan
# (3.56 GB peak, BENCHMARKS.md), with a margin; plus the interpreter and libraries.
BYTES_PER_TRIANGLE = 800
BASE_BYTES = 300e6


def available_memory():
    """Bytes of memory the system can give without swapping (MemAvailable), None if unknown."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_size(n_triangles, available=None):
    """Refuse a mesh whose processing would need more memory than is available (MeshError), rather
    than exhausting it."""
    available = available_memory() if available is None else available
    need = BYTES_PER_TRIANGLE * n_triangles + BASE_BYTES
    if available is not None and need > available:
        raise MeshError("the mesh has %d triangles: processing it needs about %.1f GB of memory, and %.1f GB are "
                        "available; decimate it (e.g. Mesh workbench > Decimation) or close other programs"
                        % (n_triangles, need / 1e9, available / 1e9))


class Mesh:
    """An indexed triangle mesh.

    vertices: (N, 3) float64, C-contiguous. faces: (M, 3) int32, C-contiguous, indices into vertices.
    Arrays that already have that layout are used as they are, without a copy.
    """

    def __init__(self, vertices, faces, source=None):
        vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        faces = np.asarray(faces)
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise MeshError("vertices must be an (N, 3) array, got shape %s" % (vertices.shape,))
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise MeshError("faces must be an (M, 3) array of vertex indices, got shape %s" % (faces.shape,))
        if faces.size and not np.issubdtype(faces.dtype, np.integer):
            raise MeshError("faces must hold integer vertex indices, got %s" % faces.dtype)
        if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
            raise MeshError("faces refer to vertex %d, but the mesh has %d vertices"
                            % (faces.max() if faces.max() >= len(vertices) else faces.min(), len(vertices)))
        if len(vertices) > np.iinfo(np.int32).max:
            raise MeshError("the mesh has too many vertices for 32-bit indices")
        self.vertices = vertices
        self.faces = np.ascontiguousarray(faces, dtype=np.int32)
        self.source = source
        self.read_info = {}

    @property
    def n_vertices(self):
        return len(self.vertices)

    @property
    def n_triangles(self):
        return len(self.faces)

    def triangle_areas(self):
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)

    def __repr__(self):
        return "<idealize.Mesh %d vertices, %d triangles%s>" % (
            self.n_vertices, self.n_triangles, ", from %r" % self.source if self.source else "")


def load_mesh(path):
    """Read an STL (binary or ASCII), OBJ, OFF or PLY file. Raises MeshError naming the problem."""
    path = os.fspath(path)
    vertices, faces, info = native.read_mesh(path)
    mesh = Mesh(vertices, faces, source=path)
    mesh.read_info = dict(info)
    return mesh
