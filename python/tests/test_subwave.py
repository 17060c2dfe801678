"""Tests of the subwave Python package: exact round trips (integers, float32, float64,
decimals read from text), quantised, keep-order, max-level, mixed polygons, hostile
bytes, the GIL released while coding, trimesh interop, and the README's example."""

import concurrent.futures
import os
import pathlib
import re
import threading
import time

import numpy as np
import pytest

import subwave

ROOT = pathlib.Path(__file__).resolve().parents[2]
CORPUS = ROOT / "corpus"
SHARED = ROOT.parent / "shared" / "corpus"
MESH_FILES = sorted(p for p in CORPUS.iterdir() if p.suffix in (".obj", ".ply", ".off", ".stl"))


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal value for value and bit for bit (-0.0 is not 0.0), with the same dtype."""
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def faces_of(mesh):
    """Each face as a tuple of corner indices."""
    flat, off = mesh.flat_faces, mesh.face_offsets
    return [tuple(flat[off[i] : off[i + 1]]) for i in range(len(off) - 1)]


def canonical_faces(vertices, faces):
    """Faces as their corners' positions (bytes), each from its smallest corner, sorted:
    a fingerprint that does not depend on vertex or face order."""
    rows = [vertices[i].tobytes() for i in range(len(vertices))]
    out = []
    for f in faces:
        c = [rows[i] for i in f]
        k = c.index(min(c))
        out.append(tuple(c[k:] + c[:k]))
    return sorted(out)


def check_round_trip(vertices, faces, offsets, **kwargs):
    data = subwave.compress(vertices, faces, face_offsets=offsets, **kwargs)
    back = subwave.decompress(data)
    source = subwave.Mesh(vertices, faces, offsets)
    if kwargs.get("keep_order"):
        assert back.order == "input"
        assert same_bits(back.vertices, vertices)
        assert faces_of(back) == faces_of(source)
    else:
        assert back.order == "canonical"
        assert back.vertices.dtype == vertices.dtype
        assert sorted(r.tobytes() for r in back.vertices) == sorted(r.tobytes() for r in vertices)
        assert canonical_faces(back.vertices, faces_of(back)) == canonical_faces(
            vertices, faces_of(source)
        )
    return data, back


@pytest.mark.parametrize("path", MESH_FILES, ids=lambda p: p.name)
def test_corpus_round_trips_exactly(path):
    mesh = subwave.read(path)
    assert mesh.order == "input" and mesh.format
    for keep in (False, True):
        # The values as read (float64 for decimals, float32 for float PLY and STL).
        check_round_trip(mesh.vertices, mesh.flat_faces, mesh.face_offsets, keep_order=keep)
        # The integers themselves.
        check_round_trip(mesh.integers, mesh.flat_faces, mesh.face_offsets, keep_order=keep)


def test_float_dtypes_are_kept_bit_for_bit():
    rng = np.random.default_rng(1)
    mesh = subwave.read(CORPUS / "cube_cc4.obj")
    for dtype in (np.float32, np.float64):
        v = (rng.standard_normal(mesh.vertices.shape) * 10.0 ** rng.integers(-8, 8, mesh.vertices.shape)).astype(dtype)
        v[0, 0] = -0.0
        v[1, 1] = np.finfo(dtype).tiny / 4  # subnormal
        data, back = check_round_trip(v, mesh.flat_faces, mesh.face_offsets, keep_order=True)
        assert np.signbit(back.vertices[0, 0])
        assert subwave.info(data)["quantization"]["kind"] == "float"


def test_quantised_and_max_level():
    mesh = subwave.read(CORPUS / "cube_cc4.obj")
    data = subwave.compress(mesh.vertices, mesh.faces, bits=16, keep_order=True)
    back = subwave.decompress(data)
    assert back.vertices.dtype == np.float32
    q = subwave.info(data)["quantization"]
    assert q["kind"] == "grid" and q["bits"] == 16
    ints = subwave.decompress(data, integers=True).vertices
    assert ints.dtype == np.int64 and ints.min() >= 0 and ints.max() < 2**16
    # Within half a grid step of the input.
    assert np.abs(back.vertices - mesh.vertices).max() <= q["step"] * 0.5 + 1e-6
    # A hierarchy's coarser levels.
    plain = subwave.compress(mesh.vertices, mesh.faces)
    full = subwave.decompress(plain)
    assert full.levels >= 2 and full.family != "none"
    coarse = subwave.decompress(plain, max_level=1)
    assert coarse.levels == 1 and len(coarse.vertices) < len(full.vertices)


def test_effort_levels_round_trip_and_differ():
    mesh = subwave.read(CORPUS / "terrain_grid33.obj")
    default = subwave.compress(mesh.vertices, mesh.faces, bits=12, keep_order=True)
    ints = subwave.decompress(default, integers=True).vertices
    sizes = {}
    for effort in (1, 6, 9):
        data = subwave.compress(mesh.vertices, mesh.faces, bits=12, keep_order=True, effort=effort)
        back = subwave.decompress(data)
        assert np.array_equal(subwave.decompress(data, integers=True).vertices, ints)
        assert back.vertices.shape == mesh.vertices.shape
        sizes[effort] = len(data)
    # The default is effort 6; the least effort codes this grid larger than the most.
    assert len(default) == sizes[6]
    assert sizes[9] < sizes[1]
    for bad in (0, 10):
        with pytest.raises(ValueError, match="effort"):
            subwave.compress(mesh.vertices, mesh.faces, effort=bad)


def test_decimals_code_text_values_on_their_grid():
    mesh = subwave.read(CORPUS / "cube_cc4.obj")
    d = mesh.quantization["decimals"]
    small, back = check_round_trip(
        mesh.vertices, mesh.flat_faces, mesh.face_offsets, keep_order=True, decimals=d
    )
    assert subwave.info(small)["quantization"] == {"kind": "decimal", "decimals": d}
    # The same values as doubles cost more: the grid is what makes text values small.
    doubles = subwave.compress(mesh.vertices, mesh.faces, keep_order=True)
    assert len(small) < len(doubles)
    # Integers with decimals stand for n / 10^d.
    back = subwave.decompress(subwave.compress(mesh.integers, mesh.faces, decimals=d, keep_order=True))
    assert np.array_equal(back.vertices, mesh.vertices)
    with pytest.raises(subwave.InvalidMeshError, match="not a number of 2 decimals"):
        subwave.compress(mesh.vertices, mesh.faces, decimals=2)


def test_mixed_polygons_use_offsets():
    mesh = subwave.read(CORPUS / "sphere_polar3.obj")
    sizes = set(np.diff(mesh.face_offsets.astype(np.int64)))
    assert len(sizes) > 1 and mesh.faces.ndim == 1
    check_round_trip(mesh.vertices, mesh.faces, mesh.face_offsets, keep_order=True)
    # A list of (m, k) faces also works where every face has k corners.
    quad = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.int32)
    back = subwave.decompress(subwave.compress(quad, [[0, 1, 2, 3]], keep_order=True))
    assert back.vertices.dtype == np.int64 and (back.vertices == quad).all()
    assert back.faces.shape == (1, 4)


def test_files_write_and_read_back(tmp_path):
    mesh = subwave.read(CORPUS / "sphere_polar3.obj")
    for ext in ("obj", "ply", "off", "stl", "swv"):
        path = tmp_path / f"m.{ext}"
        subwave.write(path, mesh)
        again = subwave.read(path)
        if ext == "stl":  # triangles and corners welded by position; values the same
            assert sorted(map(bytes, again.vertices)) == sorted(map(bytes, mesh.vertices))
            continue
        if ext == "swv":
            assert sorted(map(bytes, again.vertices)) == sorted(map(bytes, mesh.vertices))
            continue
        assert np.array_equal(again.vertices, mesh.vertices), ext
        assert faces_of(again) == faces_of(mesh), ext


def test_bad_input_raises_subwave_errors(tmp_path):
    mesh = subwave.read(CORPUS / "cube_cc4.obj")
    data = subwave.compress(mesh.vertices, mesh.faces)
    # Every truncation and some bit flips: an error or (for a flip in a payload the
    # checksums do not cover) a mesh, never a crash.
    for n in range(0, len(data), max(1, len(data) // 200)):
        with pytest.raises(subwave.Error):
            subwave.decompress(data[:n])
    for i in range(0, len(data), max(1, len(data) // 100)):
        flipped = bytearray(data)
        flipped[i] ^= 0x10
        with pytest.raises(subwave.CorruptError):
            subwave.decompress(bytes(flipped))
    with pytest.raises(subwave.CorruptError):
        subwave.info(b"not a container")
    bad = mesh.vertices.copy()
    bad[3, 1] = np.nan
    with pytest.raises(subwave.InvalidMeshError, match="NaN"):
        subwave.compress(bad, mesh.faces)
    with pytest.raises(subwave.InvalidMeshError):
        subwave.compress(mesh.vertices, np.array([[0, 1, len(mesh.vertices)]]))
    with pytest.raises(subwave.InvalidMeshError):
        subwave.compress(mesh.vertices, np.array([0, 1, 2, 3]), face_offsets=[0, 2, 4])
    with pytest.raises(ValueError):
        subwave.compress(mesh.vertices[:, :2], mesh.faces)
    with pytest.raises(subwave.InvalidMeshError, match="uv"):
        subwave.compress(mesh.vertices, mesh.faces, attributes={"uv": np.zeros((3, 2))})
    with pytest.raises(ValueError, match="domain"):
        subwave.Attribute(np.zeros((3, 2)), domain="edge")
    with pytest.raises(subwave.FileError):
        subwave.read(tmp_path / "missing.obj")
    (tmp_path / "hello.obj").write_text("Hello, world\n")
    with pytest.raises(subwave.MeshFileError, match="not an OBJ file"):
        subwave.read(tmp_path / "hello.obj")


def grid_mesh(n):
    """An n x n height field on a grid of quads, float64."""
    y, x = np.mgrid[0:n, 0:n]
    z = np.sin(x / 7.0) * np.cos(y / 5.0)
    v = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1).astype(np.float64)
    i = (y[:-1, :-1] * n + x[:-1, :-1]).ravel()
    faces = np.stack([i, i + 1, i + n + 1, i + n], axis=1)
    return v, faces


def test_gil_is_released_while_coding():
    vertices, faces = grid_mesh(300)
    # While a thread compresses, this thread keeps running Python: were the GIL held
    # for the whole call, no step of the loop below could fall inside it.
    span = {}
    ticks = []

    def work():
        span["start"] = time.perf_counter()
        span["data"] = subwave.compress(vertices, faces)
        span["end"] = time.perf_counter()

    t = threading.Thread(target=work)
    t.start()
    while t.is_alive():
        ticks.append(time.perf_counter())
    t.join()
    inside = [x for x in ticks if span["start"] < x < span["end"]]
    assert len(inside) > 100, f"{len(inside)} steps ran during compress"
    # A pool of threads decodes at once, every result exact.
    data = span["data"]
    want = subwave.decompress(data)
    with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
        for got in pool.map(lambda _: subwave.decompress(data), range(8)):
            assert same_bits(got.vertices, want.vertices)
            assert faces_of(got) == faces_of(want)


def test_trimesh_interop():
    trimesh = pytest.importorskip("trimesh")
    mesh = subwave.read(CORPUS / "cube_cc4.obj")
    tm = mesh.to_trimesh()
    assert isinstance(tm, trimesh.Trimesh)
    assert np.array_equal(tm.vertices, mesh.vertices)
    assert len(tm.faces) == 2 * len(mesh.faces)  # quads as two triangles
    # And back: a trimesh mesh's arrays go straight in.
    back = subwave.decompress(subwave.compress(tm.vertices, tm.faces, keep_order=True))
    assert same_bits(back.vertices, np.asarray(tm.vertices))
    assert np.array_equal(back.faces, tm.faces)


def test_readme_example_runs_as_written():
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## From Python", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    assert len(code.strip().splitlines()) <= 6
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        exec(compile(code, "README.md", "exec"), {})
    finally:
        os.chdir(cwd)


@pytest.mark.skipif(not (SHARED / "manifest.json").exists(), reason="../shared/corpus not found")
def test_shared_corpus_round_trips_exactly():
    files = sorted(p for p in SHARED.iterdir() if p.suffix == ".obj")
    assert len(files) >= 40
    for path in files:
        mesh = subwave.read(path)
        check_round_trip(mesh.vertices, mesh.flat_faces, mesh.face_offsets, keep_order=True, threads=2)


def test_decoder_threads_give_the_same_mesh():
    # A 129 x 129 grid of random heights: levels with enough details for the decoder's
    # work beside the reading.
    rng = np.random.default_rng(7)
    n = 129
    ys, xs = np.mgrid[0:n, 0:n]
    verts = np.stack([xs.ravel(), ys.ravel(), rng.integers(0, 4000, n * n)], axis=1).astype(np.int64)
    idx = (ys[:-1, :-1] * n + xs[:-1, :-1]).ravel()
    faces = np.stack([idx, idx + 1, idx + n + 1, idx + n], axis=1)
    data = subwave.compress(verts, faces, keep_order=True)
    one = subwave.decompress(data, threads=1)
    assert same_bits(one.vertices, verts)
    for threads in (2, 3):
        other = subwave.decompress(data, threads=threads)
        assert same_bits(other.vertices, one.vertices)
        assert faces_of(other) == faces_of(one)
    with pytest.raises(ValueError):
        subwave.decompress(data, threads=0)


def test_attribute_channels_come_back_exactly_in_canonical_order():
    # A textured OBJ's uv and normal channels, read, coded in canonical order and
    # decoded: every value, at every face corner, is the one read.
    mesh = subwave.read(CORPUS / "textured_cc3.obj")
    assert set(mesh.attributes) == {
        "object", "smoothing", "material", "lines", "uv", "normal"
    }
    assert mesh.attributes["material"].labels == [f"Side{i}" for i in range(6)]
    uv = mesh.attributes["uv"]
    assert uv.domain == "corner" and uv.values.shape[1] == 2
    rng = np.random.default_rng(7)
    weight = rng.integers(0, 255, size=len(mesh.vertices)).astype(np.uint8)
    colour = rng.random((len(mesh.vertices), 3), dtype=np.float32)
    mesh.attributes["weight"] = subwave.Attribute(weight)
    mesh.attributes["colour"] = subwave.Attribute(colour)
    data = subwave.compress(
        mesh.vertices, mesh.flat_faces, face_offsets=mesh.face_offsets,
        decimals=mesh.quantization["decimals"], attributes=mesh.attributes,
    )
    back = subwave.decompress(data)
    assert back.order == "canonical"
    assert list(back.attributes) == [
        "object", "smoothing", "material", "lines", "uv", "normal", "weight", "colour"
    ]
    # The comments and mtllib line, per file, in their order.
    lines = back.attributes["lines"]
    assert lines.domain == "file" and lines.indices is None
    assert [lines.labels[int(v)] for v in lines.values[:, 0]] == [
        "# subwave-corpus OBJ File", "# made by to_obj_textured", "mtllib textured.mtl"
    ]
    mat = back.attributes["material"]
    assert mat.domain == "face" and mat.labels == mesh.attributes["material"].labels
    assert back.attributes["weight"].type == "u8"
    assert back.attributes["colour"].values.dtype == np.float32

    def corners(m):
        # Per face: its corners' positions and channel values, from its smallest corner.
        flat, off = m.flat_faces, m.face_offsets
        out = []
        for f in range(len(off) - 1):
            rows = []
            for c in range(off[f], off[f + 1]):
                v = flat[c]
                row = tuple(m.vertices[v].tolist())
                for name in ("uv", "normal"):
                    a = m.attributes[name]
                    row += tuple(a.values[a.indices[c]].tolist())
                row += (int(m.attributes["weight"].values[v, 0]),)
                row += tuple(m.attributes["colour"].values[v].view(np.uint32).tolist())
                mat = m.attributes["material"]
                row += (mat.labels[int(mat.values[f, 0])],)
                rows.append(row)
            k = rows.index(min(rows))
            out.append(tuple(rows[k:] + rows[:k]))
        return sorted(out)

    assert corners(back) == corners(mesh)


def test_ply_lists_and_other_elements_are_channels(tmp_path):
    # A PLY with a list per vertex and another element: channels of the vertex and
    # of the file, each list's values and length kept, through canonical order too.
    header = (
        "ply\nformat ascii 1.0\ncomment a test\nelement vertex 4\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property list uchar int ids\nelement face 1\n"
        "property list uchar int vertex_indices\nelement edge 1\n"
        "property int vertex1\nproperty int vertex2\nend_header\n"
    )
    body = "0 0 0 0\n1 0 0 1 7\n1 1 0 2 8 9\n0 1 0 3 1 2 3\n4 0 1 2 3\n3 0\n"
    path = tmp_path / "lists.ply"
    path.write_text(header + body)
    mesh = subwave.read(path)
    ids = mesh.attributes["ids"]
    assert ids.domain == "vertex" and list(ids.indices) == [0, 1, 2, 3]
    assert ids.values[:, 0].tolist() == [7, 8, 9, 1, 2, 3]
    edge = mesh.attributes["edge/vertex1 vertex2"]
    assert edge.domain == "file" and edge.values.tolist() == [[3, 0]]
    assert mesh.attributes["header"].labels == ["comment a test"]
    data = subwave.compress(
        mesh.vertices, mesh.flat_faces, face_offsets=mesh.face_offsets,
        attributes=mesh.attributes,
    )
    back = subwave.decompress(data)

    def lists(m):
        # Each vertex's position with its list, and the edge's ends' positions.
        a = m.attributes["ids"]
        starts = np.concatenate([[0], np.cumsum(a.indices)]).astype(np.int64)
        per_vertex = sorted(
            (tuple(m.vertices[v].tolist()), tuple(a.values[starts[v]:starts[v + 1], 0].tolist()))
            for v in range(len(m.vertices))
        )
        e = m.attributes["edge/vertex1 vertex2"].values[0]
        return per_vertex, [tuple(m.vertices[int(i)].tolist()) for i in e]

    assert lists(back) == lists(mesh)
