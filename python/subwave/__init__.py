"""subwave: a lossless integer geometry codec for meshes with subdivision connectivity.

Numpy arrays in and out::

    import numpy as np, subwave
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
    data = subwave.compress(vertices, np.array([[0, 1, 2, 3]]))
    mesh = subwave.decompress(data)
    assert (mesh.vertices == vertices).all() and mesh.vertices.dtype == np.float32

Integers are coded as they are, float32 and float64 exactly (bit for bit), or on
Draco's grid with ``bits``. Every error is a :class:`subwave.Error`; the GIL is released
while the library codes, reads or writes, so threads decode in parallel.
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional, Union

import numpy as np

from . import _subwave
from ._subwave import (
    FORMAT_VERSION,
    CorruptError,
    Error,
    FileError,
    InvalidMeshError,
    MeshFileError,
    UnsupportedError,
    __version__,
)

__all__ = [
    "Mesh",
    "Attribute",
    "compress",
    "decompress",
    "read",
    "write",
    "info",
    "Error",
    "MeshFileError",
    "InvalidMeshError",
    "CorruptError",
    "UnsupportedError",
    "FileError",
    "FORMAT_VERSION",
    "__version__",
]


_TYPES = ("text", "f32", "f64", "i8", "u8", "i16", "u16", "i32", "u32")
_DTYPE_TYPES = {
    np.dtype(np.int8): "i8",
    np.dtype(np.uint8): "u8",
    np.dtype(np.int16): "i16",
    np.dtype(np.uint16): "u16",
    np.dtype(np.int32): "i32",
    np.dtype(np.uint32): "u32",
    np.dtype(np.float32): "f32",
    np.dtype(np.float64): "f64",
}


class Attribute:
    """A named attribute channel: texture coordinates, normals, colours, any per-vertex,
    per-face, per-corner or per-file values, kept exactly (integers as integers, floats
    bit for bit, decimals read from text on their own grid).

    Attributes:
        values: ``(entries, width)`` array, ``width`` 1 to 3, in the type the values
            came in (as ``Mesh.vertices``).
        domain: ``"vertex"`` (an entry per vertex), ``"face"`` (per face) or
            ``"corner"`` (a table of entries, ``indices`` naming one per face corner:
            an OBJ's ``vt`` with its faces' ``v/vt``) or ``"file"`` (any number of
            entries of the file as a whole: an OBJ's comment and ``mtllib`` lines as
            ``lines``, a PLY's header comments as ``header`` and its other elements'
            properties as ``element/properties``).
        indices: for ``"corner"``, the entry of each face corner (in the order of
            ``Mesh.flat_faces``; 2**32 - 1 for none: an OBJ face without ``vt``
            numbers among faces with them); for a *list channel* of another domain (a PLY list
            property: any number of values per vertex, face or record, one per row of
            ``values``, each record's in turn), the number of values of each; else
            ``None``.
        type: how the values are written to a file: ``"text"``, ``"f32"``, ``"f64"``,
            ``"i8"``, ``"u8"``, ``"i16"``, ``"u16"``, ``"i32"``, ``"u32"`` (a PLY
            property's type); ``None`` chooses from the array's dtype.
        quantization: how the coded integers map to values (``subwave info``'s JSON),
            for values decoded or read.
        labels: for a channel of names (an OBJ's ``object``, ``group``, ``smoothing``
            and ``material`` per face, its ``lines``), the names its integer values stand for (value
            ``i`` is ``labels[i]``, -1 none); else empty.
    """

    def __init__(
        self,
        values,
        domain: str = "vertex",
        indices=None,
        type: Optional[str] = None,
        quantization: Optional[Dict[str, Any]] = None,
        labels: Optional[list] = None,
    ) -> None:
        v = np.asarray(values)
        if v.ndim == 1:
            v = v.reshape(-1, 1)
        if v.ndim != 2 or not 1 <= v.shape[1] <= 3:
            raise ValueError(f"attribute values must have shape (n, 1..3), not {v.shape}")
        if domain not in ("vertex", "face", "corner", "file"):
            raise ValueError(f"domain must be vertex, face, corner or file, not {domain!r}")
        if indices is None and domain == "corner":
            raise ValueError("a corner attribute needs indices")
        if type is None:
            type = _DTYPE_TYPES.get(v.dtype, "text")
        if type not in _TYPES:
            raise ValueError(f"type must be one of {', '.join(_TYPES)}, not {type!r}")
        self.values = v
        self.domain = domain
        self.indices = None if indices is None else np.asarray(indices)
        self.type = type
        self.quantization = quantization
        self.labels = [str(x) for x in (labels or [])]

    def __repr__(self) -> str:
        return (
            f"subwave.Attribute({self.values.shape[0]} x {self.values.shape[1]} "
            f"{self.values.dtype}, domain={self.domain!r}, type={self.type!r})"
        )

    def _given(self, name: str):
        """As the extension takes it: values padded to three columns."""
        v = _vertices(
            np.concatenate(
                [self.values, np.zeros((len(self.values), 3 - self.values.shape[1]), self.values.dtype)],
                axis=1,
            ),
            what=f"attribute {name!r} values",
        )
        idx = None
        if self.indices is not None:
            idx = np.asarray(self.indices)
            if idx.size and (idx.min() < 0 or idx.max() > np.iinfo(np.uint32).max):
                raise InvalidMeshError(f"attribute {name!r}: indices must be between 0 and 2^32 - 1")
            idx = np.ascontiguousarray(idx.reshape(-1), dtype=np.uint32)
        return ((name, self.domain, self.type, v, idx, self.labels), int(self.values.shape[1]))


def _given_attributes(attributes) -> list:
    """A dict of :class:`Attribute` (or per-vertex arrays) as the extension takes it."""
    out = []
    for name, a in (attributes or {}).items():
        if not isinstance(a, Attribute):
            a = Attribute(a)
        out.append(a._given(str(name)))
    return out


class Mesh:
    """A mesh: positions and polygon faces.

    Attributes:
        vertices: ``(n, 3)`` array, in the type the values came in: int64 for integers,
            float32 / float64 for binary floats (exact), float64 for decimal text (the
            nearest double; ``integers`` and ``quantization`` hold it exactly), float32
            for a ``bits`` grid (Draco's dequantised values).
        faces: ``(m, k)`` array when every face has ``k`` corners, else the flat
            ``(sum of k,)`` array of corner indices; see ``face_offsets``.
        face_offsets: ``(m + 1,)`` array: face ``i`` is ``flat[face_offsets[i]:
            face_offsets[i + 1]]``.
        attributes: named :class:`Attribute` channels (texture coordinates ``uv``,
            normals ``normal``, colours ``color`` from an OBJ; a PLY's vertex and face
            properties, named by them, e.g. ``"red green blue"``).
        levels: refinement levels found (0 for a flat mesh or one read from a file).
        family: ``"cc"``, ``"sqrt2"``, ``"polar"`` or ``"none"``.
        order: ``"input"`` when the vertices and faces are in the order they were given
            (``keep_order=True``, or a file read), ``"canonical"`` otherwise.
        integers: ``(n, 3)`` int64, the coded integers.
        quantization: how ``integers`` map to values (``subwave info``'s JSON).
        format: the file format a mesh was read from, else ``None``.
        dropped: what a file held that subwave does not carry.
    """

    def __init__(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        face_offsets: Optional[np.ndarray] = None,
        *,
        attributes: Optional[Dict[str, Attribute]] = None,
        levels: int = 0,
        family: str = "none",
        order: str = "input",
        integers: Optional[np.ndarray] = None,
        quantization: Optional[Dict[str, Any]] = None,
        format: Optional[str] = None,
        dropped: Optional[list] = None,
    ) -> None:
        self.vertices = vertices
        flat, offsets = _flat_faces(faces, face_offsets)
        self.face_offsets = offsets
        self.faces = _shaped_faces(flat, offsets)
        self.attributes = dict(attributes or {})
        self.levels = levels
        self.family = family
        self.order = order
        self.integers = integers
        self.quantization = quantization
        self.format = format
        self.dropped = list(dropped or [])

    def __repr__(self) -> str:
        return (
            f"subwave.Mesh({len(self.vertices)} vertices {self.vertices.dtype}, "
            f"{len(self.face_offsets) - 1} faces, levels={self.levels}, "
            f"family={self.family!r}, order={self.order!r})"
        )

    @property
    def flat_faces(self) -> np.ndarray:
        """Every face's corner indices, one after the other (see ``face_offsets``)."""
        return np.asarray(self.faces).reshape(-1)

    def to_trimesh(self, **kwargs: Any):
        """This mesh as a ``trimesh.Trimesh`` (trimesh must be installed). Polygons
        are split into triangle fans, as trimesh holds triangles only; ``process=False``
        unless given, so that vertices are neither merged nor reordered."""
        import trimesh  # an optional dependency

        flat, off = self.flat_faces, self.face_offsets
        tris = [
            (flat[off[i]], flat[off[i] + j], flat[off[i] + j + 1])
            for i in range(len(off) - 1)
            for j in range(1, off[i + 1] - off[i] - 1)
        ]
        kwargs.setdefault("process", False)
        return trimesh.Trimesh(
            vertices=self.vertices, faces=np.array(tris, dtype=np.int64).reshape(-1, 3), **kwargs
        )


def _flat_faces(faces, face_offsets):
    """Faces as a flat uint32 array and uint32 offsets."""
    faces = np.asarray(faces)
    if faces.size and not np.issubdtype(faces.dtype, np.integer):
        raise TypeError(f"faces must be integers, not {faces.dtype}")
    # uint32 arrays (a decoded mesh's) are in range by their type.
    if faces.size and faces.dtype != np.uint32 and (
        faces.min() < 0 or faces.max() > np.iinfo(np.uint32).max
    ):
        raise InvalidMeshError("face indices must be between 0 and 2^32 - 1")
    if face_offsets is not None:
        flat = faces.reshape(-1)
        offsets = np.asarray(face_offsets)
        if offsets.dtype != np.uint32:
            offsets = np.asarray(offsets, dtype=np.int64)
    elif faces.ndim == 2:
        m, k = faces.shape
        flat = faces.reshape(-1)
        offsets = np.arange(m + 1, dtype=np.int64) * k
    elif faces.size == 0:
        flat, offsets = faces.reshape(-1), np.zeros(1, dtype=np.int64)
    else:
        raise ValueError("faces must be an (m, k) array, or flat with face_offsets")
    if (
        offsets.size
        and offsets.dtype != np.uint32
        and (offsets.min() < 0 or offsets.max() > np.iinfo(np.uint32).max)
    ):
        raise InvalidMeshError("face offsets must be between 0 and 2^32 - 1")
    return (
        np.ascontiguousarray(flat, dtype=np.uint32),
        np.ascontiguousarray(offsets, dtype=np.uint32),
    )


def _shaped_faces(flat: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """``(m, k)`` where every face has ``k`` corners, else the flat array."""
    sizes = np.diff(offsets.astype(np.int64))
    if len(sizes) and (sizes == sizes[0]).all():
        return flat.reshape(len(sizes), int(sizes[0]))
    return flat


def _vertices(vertices, what: str = "vertices") -> np.ndarray:
    """Positions as the extension takes them: (n, 3) int64, float32 or float64."""
    v = np.asarray(vertices)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"{what} must have shape (n, 3), not {v.shape}")
    if v.dtype in (np.float32, np.float64):
        return np.ascontiguousarray(v)
    if np.issubdtype(v.dtype, np.integer):
        if v.dtype == np.uint64 and v.size and v.max() > np.iinfo(np.int64).max:
            raise InvalidMeshError(f"integer {what} beyond int64")
        return np.ascontiguousarray(v, dtype=np.int64)
    if np.issubdtype(v.dtype, np.floating):  # float16: exactly a float32
        return np.ascontiguousarray(v, dtype=np.float32)
    raise TypeError(f"{what} must be integers or floats, not {v.dtype}")


def _mesh(parts, **extra) -> Mesh:
    values, integers, flat, offsets, quant, channels = parts
    attributes = {
        name: Attribute(v, domain, indices, ty, json.loads(q), labels)
        for name, domain, ty, v, indices, q, labels in channels
    }
    return Mesh(
        values,
        flat,
        offsets,
        integers=integers,
        quantization=json.loads(quant),
        attributes=attributes,
        **extra,
    )


def compress(
    vertices,
    faces,
    *,
    face_offsets=None,
    bits: Optional[int] = None,
    keep_order: bool = False,
    decimals: Optional[int] = None,
    effort: Optional[int] = None,
    attributes: Optional[Dict[str, np.ndarray]] = None,
    threads: int = 1,
) -> bytes:
    """Compresses a mesh into a ``.swv`` container.

    Args:
        vertices: ``(n, 3)`` positions: integers are coded as they are, float32 and
            float64 exactly, bit for bit (with ``bits``, on Draco's grid instead).
        faces: ``(m, k)`` corner indices, or a flat index array with ``face_offsets``
            (``m + 1`` offsets, face ``i`` is ``faces[face_offsets[i]:face_offsets[i+1]]``)
            for mixed polygons. Faces need at least 3 corners.
        bits: quantise to Draco's ``bits``-bit grid (1..30): lossy, compares 1:1 with
            Draco at the same setting.
        keep_order: store the input's vertex and face order, which ``decompress``
            restores (otherwise a canonical order, ``Mesh.order == "canonical"``).
        decimals: the values are decimal numbers of this many decimals (as text files
            write them): coded on that decimal grid, far smaller than their doubles.
            Integers ``n`` then stand for ``n / 10**decimals``; floats must be the
            nearest doubles of such numbers (else :class:`InvalidMeshError`), and come
            back as those doubles. A mesh read from a text file says its decimals in
            ``mesh.quantization["decimals"]``.
        effort: how hard the encoder searches, 1 (fastest) to 9 (every candidate,
            transform and mode: the smallest container); ``None`` is the default (6).
            Any effort decodes the same way.
        attributes: named :class:`Attribute` channels (or ``(n, 1..3)`` arrays, one
            row per vertex), each value kept exactly as given (integers as integers,
            floats bit for bit), in the order the vertices and faces come back in.
        threads: threads the encoder may use to try transforms at once; the container
            is the same for any count.

    Returns:
        The container's bytes.
    """
    if effort is not None and not 1 <= int(effort) <= 9:
        raise ValueError(f"effort must be between 1 and 9 (given: {effort})")
    given = _given_attributes(attributes)
    flat, offsets = _flat_faces(faces, face_offsets)
    return _subwave.compress(
        _vertices(vertices),
        flat,
        offsets,
        bits,
        bool(keep_order),
        max(1, int(threads)),
        decimals,
        None if effort is None else int(effort),
        given,
    )


def decompress(
    data: Union[bytes, bytearray, memoryview],
    *,
    max_level: Optional[int] = None,
    integers: bool = False,
    threads: int = 1,
) -> Mesh:
    """Decompresses a container into a :class:`Mesh`.

    Args:
        data: the container's bytes.
        max_level: decode only up to refinement level ``max_level`` (0 = the base mesh);
            also works on a container cut off after that level.
        integers: give ``vertices`` as the coded int64 integers instead of values.
        threads: threads the decoder may use (the mesh is the same for every count).
    """
    if threads < 1:
        raise ValueError(f"threads must be at least 1, not {threads}")
    parts, levels, family, input_order = _subwave.decompress(bytes(data), max_level, threads)
    mesh = _mesh(
        parts,
        levels=levels,
        family=family,
        order="input" if input_order else "canonical",
    )
    if integers:
        mesh.vertices = mesh.integers
    return mesh


def read(path: Union[str, os.PathLike]) -> Mesh:
    """Reads a mesh file (OBJ, PLY, OFF, STL: exact values) or a ``.swv`` container."""
    path = os.fspath(path)
    if path.lower().endswith(".swv"):
        with open(path, "rb") as f:
            return decompress(f.read())
    parts, fmt, dropped = _subwave.read(path)
    return _mesh(parts, format=fmt, dropped=dropped)


def write(path: Union[str, os.PathLike], mesh: Mesh, **compress_args: Any) -> None:
    """Writes a mesh to a file, its format from the extension: ``.obj``, ``.ply``,
    ``.off``, ``.stl`` (values written exactly: PLY and STL in ASCII where binary floats
    cannot hold them) or ``.swv`` (``compress_args`` as for :func:`compress`; a mesh
    read from text is coded on its decimal grid unless they say otherwise)."""
    path = os.fspath(path)
    flat, offsets = mesh.flat_faces, mesh.face_offsets
    if path.lower().endswith(".swv"):
        q = mesh.quantization or {}
        if q.get("kind") == "decimal" and "bits" not in compress_args:
            # Values read from text: on their own decimal grid.
            compress_args.setdefault("decimals", q["decimals"])
        compress_args.setdefault("attributes", mesh.attributes)
        data = compress(mesh.vertices, flat, face_offsets=offsets, **compress_args)
        with open(path, "wb") as f:
            f.write(data)
        return
    if compress_args:
        raise ValueError("compress arguments apply to .swv files only")
    flat, offsets = _flat_faces(flat, offsets)
    _subwave.write(path, _vertices(mesh.vertices), flat, offsets, _given_attributes(mesh.attributes))


def info(data: Union[bytes, bytearray, memoryview]) -> Dict[str, Any]:
    """What ``subwave info --json`` prints of a container: counts, family, transform,
    quantisation, flags and sections."""
    return json.loads(_subwave.info(bytes(data)))
