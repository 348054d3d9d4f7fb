"""Writers for small test meshes in every format Idealize reads.

Each writer takes vertices V (N x 3) and triangles F (M x 3, indices from 0) and writes exactly
those triangles in that order, so a reader's output can be compared face by face.
"""

import struct

import numpy as np


def cube_mesh():
    """Unit cube [0, 1]^3: 8 vertices, 12 triangles, counter-clockwise seen from outside."""
    V = np.array(
        [
            [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
            [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1],
        ],
        dtype=np.float64,
    )
    F = np.array(
        [
            [0, 2, 1], [0, 3, 2],  # z = 0
            [4, 5, 6], [4, 6, 7],  # z = 1
            [0, 1, 5], [0, 5, 4],  # y = 0
            [3, 7, 6], [3, 6, 2],  # y = 1
            [0, 4, 7], [0, 7, 3],  # x = 0
            [1, 2, 6], [1, 6, 5],  # x = 1
        ],
        dtype=np.int32,
    )
    return V, F


def _normals(V, F):
    a, b, c = (np.asarray(V, dtype=np.float64)[np.asarray(F)[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(length > 0, length, 1)


def write_binary_stl(path, V, F, header=b"binary STL written by Idealize tests", count=None):
    """`count` overrides the triangle count in the header (to fake a truncated file)."""
    V, F = np.asarray(V), np.asarray(F)
    with open(path, "wb") as f:
        f.write(header[:80].ljust(80, b" "))
        f.write(struct.pack("<I", len(F) if count is None else count))
        for n, tri in zip(_normals(V, F), F):
            f.write(struct.pack("<3f", *n))
            for v in tri:
                f.write(struct.pack("<3f", *V[v]))
            f.write(b"\0\0")


def write_ascii_stl(path, V, F, name="cube", newline="\n"):
    lines = ["solid " + name]
    for n, tri in zip(_normals(V, F), np.asarray(F)):
        lines.append("  facet normal %r %r %r" % tuple(float(x) for x in n))
        lines.append("    outer loop")
        for v in tri:
            lines.append("      vertex %r %r %r" % tuple(float(x) for x in V[v]))
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append("endsolid " + name)
    with open(path, "w", newline="") as f:
        f.write(newline.join(lines) + newline)


def write_obj(path, V, F):
    with open(path, "w") as f:
        f.write("# written by Idealize tests\n")
        for v in np.asarray(V, dtype=np.float64):
            f.write("v %r %r %r\n" % tuple(float(x) for x in v))
        for tri in np.asarray(F):
            f.write("f %d %d %d\n" % tuple(int(i) + 1 for i in tri))


def write_off(path, V, F):
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(V), len(F)))
        for v in np.asarray(V, dtype=np.float64):
            f.write("%r %r %r\n" % tuple(float(x) for x in v))
        for tri in np.asarray(F):
            f.write("3 %d %d %d\n" % tuple(int(i) for i in tri))


def write_ply(path, V, F, binary=False, big_endian=False, vertex_count=None):
    """Vertices carry float x, y, z plus a normal and a colour; faces a uchar/int index list plus a
    flag; an extra 'edge' element with a list follows, as real exporters write them.
    `vertex_count` overrides the count in the header (to fake a lying header)."""
    V, F = np.asarray(V, dtype=np.float64), np.asarray(F)
    normals = np.zeros_like(V)
    edges = [(0, [1, 2]), (1, [2])]
    header = [
        "ply",
        "format %s 1.0" % ("ascii" if not binary else
                           "binary_big_endian" if big_endian else "binary_little_endian"),
        "comment written by Idealize tests",
        "element vertex %d" % (len(V) if vertex_count is None else vertex_count),
        "property float32 x",
        "property float nx",
        "property float y",
        "property float ny",
        "property float z",
        "property float nz",
        "property uchar red",
        "property uint8 green",
        "property uchar blue",
        "element face %d" % len(F),
        "property list uchar int vertex_indices",
        "property uchar flags",
        "element edge %d" % len(edges),
        "property int vertex1",
        "property list uint8 uint32 others",
        "end_header",
    ]
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode())
        if not binary:
            for v, n in zip(V, normals):
                values = (v[0], n[0], v[1], n[1], v[2], n[2])
                f.write(b"%r %r %r %r %r %r 10 20 30\n" % tuple(float(x) for x in values))
            for tri in F:
                f.write(b"3 %d %d %d 7\n" % tuple(int(i) for i in tri))
            for first, others in edges:
                f.write(("%d %d %s\n" % (first, len(others), " ".join(map(str, others)))).encode())
            return
        e = ">" if big_endian else "<"
        for v, n in zip(V, normals):
            f.write(struct.pack(e + "6f3B", v[0], n[0], v[1], n[1], v[2], n[2], 10, 20, 30))
        for tri in F:
            f.write(struct.pack(e + "B3iB", 3, *(int(i) for i in tri), 7))
        for first, others in edges:
            f.write(struct.pack(e + "iB%dI" % len(others), first, len(others), *others))
