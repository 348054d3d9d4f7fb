"""Mesh file reading: every format round-trips, odd but valid files load, and every broken file
raises idealize.MeshError with a message that names the problem."""

import struct

import numpy as np
import pytest

import idealize
from data_builders import (cube_mesh, write_ascii_stl, write_binary_stl, write_obj, write_off,
                           write_ply)


def load(path):
    mesh = idealize.load_mesh(str(path))
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    assert V.dtype == np.float64 and V.ndim == 2 and V.shape[1] == 3
    assert F.dtype == np.int32 and F.ndim == 2 and F.shape[1] == 3
    return V, F


def first_occurrence_order(F):
    """Vertex order after STL welding: as the corners first appear."""
    _, first = np.unique(np.asarray(F).ravel(), return_index=True)
    return np.asarray(F).ravel()[np.sort(first)]


def write_text(path, text):
    path.write_bytes(text.encode())
    return path


# --- the test data itself ----------------------------------------------------------------------

def test_cube_mesh_is_closed_and_outward():
    V, F = cube_mesh()
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
    assert volume == pytest.approx(1.0)
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()


# --- round trips -------------------------------------------------------------------------------

@pytest.mark.parametrize("writer", [write_binary_stl, write_ascii_stl])
def test_stl_round_trip_welds_corners(tmp_path, writer):
    V0, F0 = cube_mesh()
    path = tmp_path / "cube.stl"
    writer(path, V0, F0)
    V, F = load(path)
    assert V.shape == (8, 3) and F.shape == (12, 3)
    np.testing.assert_array_equal(V, V0[first_occurrence_order(F0)])
    np.testing.assert_array_equal(V[F], V0[F0])  # same triangles, same order, same corners


@pytest.mark.parametrize(
    "name, writer",
    [
        ("cube.obj", write_obj),
        ("cube.off", write_off),
        ("cube.ply", lambda p, V, F: write_ply(p, V, F)),
        ("cube_le.ply", lambda p, V, F: write_ply(p, V, F, binary=True)),
        ("cube_be.ply", lambda p, V, F: write_ply(p, V, F, binary=True, big_endian=True)),
    ],
)
def test_indexed_formats_round_trip_exactly(tmp_path, name, writer):
    V0, F0 = cube_mesh()
    path = tmp_path / name
    writer(path, V0, F0)
    V, F = load(path)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)


def test_extension_is_case_insensitive(tmp_path):
    V0, F0 = cube_mesh()
    write_obj(tmp_path / "CUBE.OBJ", V0, F0)
    V, F = load(tmp_path / "CUBE.OBJ")
    np.testing.assert_array_equal(F, F0)


def test_unknown_extension_is_sniffed(tmp_path):
    V0, F0 = cube_mesh()
    for name, writer in [("a.mesh", write_obj), ("b.mesh", write_off), ("c.mesh", write_ply),
                         ("d.mesh", write_ascii_stl), ("e.mesh", write_binary_stl)]:
        writer(tmp_path / name, V0, F0)
        V, F = load(tmp_path / name)
        np.testing.assert_array_equal(V[F], V0[F0])


# --- STL -----------------------------------------------------------------------------------------

def test_binary_stl_whose_header_starts_with_solid(tmp_path):
    V0, F0 = cube_mesh()
    path = tmp_path / "solidworks.stl"
    write_binary_stl(path, V0, F0, header=b"solid part exported by a CAD program")
    V, F = load(path)
    assert F.shape == (12, 3)
    np.testing.assert_array_equal(V[F], V0[F0])


def test_ascii_stl_with_several_solids_crlf_tabs_and_upper_case(tmp_path):
    text = (
        "solid first part\r\n"
        "facet normal 0 0 1\r\n\touter loop\r\n"
        "\t\tvertex 0 0 0\r\n\t\tvertex 1 0 0\r\n\t\tvertex 0 1 0\r\n"
        "\tendloop\r\nendfacet\r\n"
        "endsolid first part\r\n"
        "SOLID second\r\n"
        "FACET NORMAL 0 0 0 OUTER LOOP VERTEX 1 0 0 VERTEX 1 1 0 VERTEX +0.0 1e0 0.0 "
        "ENDLOOP ENDFACET\r\n"
        "ENDSOLID second\r\n"
    )
    V, F = load(write_text(tmp_path / "two.stl", text))
    np.testing.assert_array_equal(V, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    np.testing.assert_array_equal(F, [[0, 1, 2], [1, 3, 2]])


def test_ascii_stl_ignores_unparsable_normals(tmp_path):
    text = ("solid s\nfacet normal -1.#IND00 -1.#IND00 -1.#IND00\nouter loop\nvertex 0 0 0\n"
            "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n")
    V, F = load(write_text(tmp_path / "msvc.stl", text))
    np.testing.assert_array_equal(F, [[0, 1, 2]])


def test_stl_welds_negative_and_positive_zero(tmp_path):
    V0 = np.array([[0.0, 0.0, 0.0], [1, 0, 0], [0, 1, 0], [-0.0, -0.0, -0.0], [0, 0, 1]])
    F0 = np.array([[0, 1, 2], [3, 2, 1], [3, 4, 1]])
    write_binary_stl(tmp_path / "zeros.stl", V0, F0)
    V, F = load(tmp_path / "zeros.stl")
    assert V.shape == (4, 3)
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 1], [0, 3, 1]])


def test_stl_keeps_degenerate_triangles(tmp_path):
    V0, F0 = cube_mesh()
    F0 = np.vstack([F0, [[1, 1, 2]]])
    write_binary_stl(tmp_path / "degenerate.stl", V0, F0)
    V, F = load(tmp_path / "degenerate.stl")
    assert F.shape == (13, 3)
    assert F[12, 0] == F[12, 1] != F[12, 2]


# --- OBJ -----------------------------------------------------------------------------------------

def test_obj_face_forms_polygons_and_negative_indices(tmp_path):
    text = """# square and a triangle
mtllib scene.mtl
o square
v 0 0 0 1.0 0.5 0.5 0.5
v 1 0 0
v 1 1 0
v\t0\t1\t0
vt 0 0
vt 1 0
vt 1 1
vn 0 0 1
g faces
usemtl red
s off
f 1/1/1 2/2/1 3/3/1 4//1
f -4 -3 -2   # the last four vertices, counted back
f 1/1 3/3 4/2
l 1 2
"""
    V, F = load(write_text(tmp_path / "forms.obj", text))
    np.testing.assert_array_equal(V, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3]])


def test_obj_negative_indices_are_relative_to_the_latest_vertex(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nf -4 -1 -3\n"
    V, F = load(write_text(tmp_path / "relative.obj", text))
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 3, 1]])


# --- OFF -----------------------------------------------------------------------------------------

def test_off_with_comments_polygons_and_colours(tmp_path):
    text = """COFF
# a square and a triangle, with colours
4 2 0

0 0 0 255 0 0 255
1 0 0 255 0 0 255
1 1 0 255 0 0 255  # corner
0 1 0 255 0 0 255
4 0 1 2 3 0.5 0.5 0.5
3 3 2 1
"""
    V, F = load(write_text(tmp_path / "square.off", text))
    np.testing.assert_array_equal(V, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [3, 2, 1]])


def test_off_without_keyword(tmp_path):
    V, F = load(write_text(tmp_path / "bare.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"))
    np.testing.assert_array_equal(F, [[0, 1, 2]])


# --- PLY -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt, endian", [("ascii", None), ("binary_little_endian", "<"),
                                         ("binary_big_endian", ">")])
def test_ply_types_polygons_and_extra_elements(tmp_path, fmt, endian):
    header = f"""ply
format {fmt} 1.0
obj_info exporter test
element material 2
property uchar r
property list int int ids
element vertex 4
property double x
property int16 flags
property double y
property double z
property list uint8 float32 weights
element face 2
property int32 extra
property list int uint32 vertex_index
end_header
"""
    path = tmp_path / f"{fmt}.ply"
    vertices = [(0.5, 0, -1.25), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    faces = [[0, 1, 2, 3], [3, 2, 1]]
    if endian is None:
        body = "1 2 5 6\n2 0\n"
        body += "".join(f"{x} 7 {y} {z} 2 0.1 0.2\n" for x, y, z in vertices)
        body += "".join(f"9 {len(f)} {' '.join(map(str, f))}\n" for f in faces)
        path.write_bytes((header + body).encode())
    else:
        body = struct.pack(endian + "Bi2i", 1, 2, 5, 6) + struct.pack(endian + "Bi", 2, 0)
        for x, y, z in vertices:
            body += struct.pack(endian + "dhddB2f", x, 7, y, z, 2, 0.1, 0.2)
        for f in faces:
            body += struct.pack(endian + "ii%dI" % len(f), 9, len(f), *f)
        path.write_bytes(header.encode() + body)
    V, F = load(path)
    np.testing.assert_array_equal(V, vertices)
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3], [3, 2, 1]])


# --- errors --------------------------------------------------------------------------------------

def test_mesh_error_is_an_exception():
    assert issubclass(idealize.MeshError, Exception)


def test_missing_file(tmp_path):
    with pytest.raises(idealize.MeshError, match="cannot open .*missing.stl.*No such file"):
        idealize.load_mesh(str(tmp_path / "missing.stl"))


def test_empty_file(tmp_path):
    (tmp_path / "empty.obj").write_bytes(b"")
    with pytest.raises(idealize.MeshError, match="empty.obj' is empty"):
        idealize.load_mesh(str(tmp_path / "empty.obj"))


@pytest.mark.parametrize("header", [b"plain header", b"solid header of a binary file"])
def test_truncated_binary_stl(tmp_path, header):
    V0, F0 = cube_mesh()
    path = tmp_path / "cut.stl"
    write_binary_stl(path, V0, F0, header=header, count=1000)
    message = "is truncated: header announces 1000 triangles but only 12 are present"
    with pytest.raises(idealize.MeshError, match=message):
        idealize.load_mesh(str(path))


@pytest.mark.parametrize("size", [20, 1000])
def test_garbage_with_stl_extension(tmp_path, size):
    path = tmp_path / "garbage.stl"
    path.write_bytes((bytes(range(256)) * 4)[:size])
    with pytest.raises(idealize.MeshError, match="garbage.stl' is truncated"):
        idealize.load_mesh(str(path))


def test_text_with_stl_extension_that_is_not_stl(tmp_path):
    path = write_text(tmp_path / "notes.stl", "These are my notes, not a mesh.\n")
    with pytest.raises(idealize.MeshError, match="does not start with 'solid'"):
        idealize.load_mesh(str(path))


def test_ascii_stl_cut_inside_a_facet(tmp_path):
    V0, F0 = cube_mesh()
    path = tmp_path / "cut_ascii.stl"
    write_ascii_stl(path, V0, F0)
    path.write_bytes(path.read_bytes()[:300])
    with pytest.raises(idealize.MeshError, match="truncated|line"):
        idealize.load_mesh(str(path))


def test_ascii_stl_syntax_error_names_the_line(tmp_path):
    text = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\nendloop\n"
    with pytest.raises(idealize.MeshError, match="line 6: expected a number but found 'endloop'"):
        idealize.load_mesh(str(write_text(tmp_path / "bad.stl", text)))


def test_not_a_mesh_format(tmp_path):
    path = write_text(tmp_path / "readme.txt", "Idealize turns meshes into CAD.\nEnjoy!\n")
    message = r"readme.txt' is not a mesh format Idealize reads \(STL, OBJ, OFF, PLY\)"
    with pytest.raises(idealize.MeshError, match=message):
        idealize.load_mesh(str(path))


@pytest.mark.parametrize(
    "name, text, message",
    [
        ("nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n",
         r"coordinates contain NaN or infinity \(vertex 2\)"),
        ("inf.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n",
         r"coordinates contain NaN or infinity \(vertex 2\)"),
        ("nan.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                    "end_header\n0 0 0\n1 0 0\n0 1 NaN\n3 0 1 2\n",
         r"nan.ply': coordinates contain NaN or infinity \(vertex 2\)"),
        ("nan.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                    "vertex 0 1e999 0\nendloop\nendfacet\nendsolid s\n",
         "line 6: coordinates contain NaN or infinity"),
    ],
)
def test_non_finite_coordinates(tmp_path, name, text, message):
    with pytest.raises(idealize.MeshError, match=message):
        idealize.load_mesh(str(write_text(tmp_path / name, text)))


def test_non_finite_coordinate_in_binary_stl(tmp_path):
    V0, F0 = cube_mesh()
    V0[6, 2] = np.nan
    write_binary_stl(tmp_path / "nan.stl", V0, F0)
    with pytest.raises(idealize.MeshError, match=r"NaN or infinity \(triangle 3\)"):
        idealize.load_mesh(str(tmp_path / "nan.stl"))


@pytest.mark.parametrize(
    "text, message",
    [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 42\n",
         "line 4: face refers to vertex 42 but only 3 vertices are defined"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n",
         "line 4: face refers to vertex -4 but only 3 vertices are defined"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4: vertex index 0 is invalid"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4: face has 2 vertices"),
        ("v 0 0 0\nv 1 0\n", "line 2: a vertex needs three coordinates"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n", "line 4: 'two' is not a vertex reference"),
    ],
)
def test_obj_errors(tmp_path, text, message):
    with pytest.raises(idealize.MeshError, match=message):
        idealize.load_mesh(str(write_text(tmp_path / "bad.obj", text)))


@pytest.mark.parametrize("binary", [False, True])
def test_ply_header_announcing_more_vertices_than_present(tmp_path, binary):
    V0, F0 = cube_mesh()
    path = tmp_path / "lying.ply"
    write_ply(path, V0, F0, binary=binary, vertex_count=1000)
    with pytest.raises(idealize.MeshError, match="lying.ply' is truncated"):
        idealize.load_mesh(str(path))


def test_ply_header_announcing_billions_of_vertices(tmp_path):
    text = ("ply\nformat binary_little_endian 1.0\nelement vertex 2147483647\nproperty float x\n"
            "property float y\nproperty float z\nelement face 2147483647\n"
            "property list uchar int vertex_indices\nend_header\n")
    path = tmp_path / "huge.ply"
    path.write_bytes(text.encode() + bytes(40))
    with pytest.raises(idealize.MeshError, match="truncated"):
        idealize.load_mesh(str(path))


@pytest.mark.parametrize(
    "body, message",
    [
        ("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "face 0 refers to vertex 3 but only 3 vertices"),
        ("0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "face 0 has 2 vertices"),
    ],
)
def test_ply_face_errors(tmp_path, body, message):
    header = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
              "end_header\n")
    with pytest.raises(idealize.MeshError, match=message):
        idealize.load_mesh(str(write_text(tmp_path / "bad.ply", header + body)))


def test_ply_without_end_header(tmp_path):
    path = write_text(tmp_path / "open.ply", "ply\nformat ascii 1.0\nelement vertex 3\n")
    with pytest.raises(idealize.MeshError, match="end_header"):
        idealize.load_mesh(str(path))


def test_off_with_zero_faces(tmp_path):
    path = write_text(tmp_path / "points.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n")
    with pytest.raises(idealize.MeshError, match="points.off' contains no triangles"):
        idealize.load_mesh(str(path))


@pytest.mark.parametrize(
    "text, message",
    [
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
         "line 6: face refers to vertex 3 but only 3 vertices are defined"),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "line 6: face has 2 vertices"),
        ("OFF\n300 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "is truncated"),
        ("OFF\n2000000000 2000000000 0\n0 0 0\n", "is truncated"),
    ],
)
def test_off_errors(tmp_path, text, message):
    with pytest.raises(idealize.MeshError, match=message):
        idealize.load_mesh(str(write_text(tmp_path / "bad.off", text)))
