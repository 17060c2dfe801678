"""Type stubs of the subwave package (see ``__init__.py`` for the documentation)."""

import os
from typing import Any, Dict, List, Optional, Union

import numpy as np

__version__: str
FORMAT_VERSION: int

class Error(Exception): ...
class MeshFileError(Error): ...
class InvalidMeshError(Error): ...
class CorruptError(Error): ...
class UnsupportedError(Error): ...
class FileError(Error): ...

class Attribute:
    values: np.ndarray
    domain: str
    indices: Optional[np.ndarray]
    type: str
    quantization: Optional[Dict[str, Any]]
    labels: List[str]
    def __init__(
        self,
        values: np.ndarray,
        domain: str = ...,
        indices: Optional[np.ndarray] = ...,
        type: Optional[str] = ...,
        quantization: Optional[Dict[str, Any]] = ...,
        labels: Optional[List[str]] = ...,
    ) -> None: ...

class Mesh:
    vertices: np.ndarray
    faces: np.ndarray
    face_offsets: np.ndarray
    attributes: Dict[str, Attribute]
    levels: int
    family: str
    order: str
    integers: Optional[np.ndarray]
    quantization: Optional[Dict[str, Any]]
    format: Optional[str]
    dropped: List[str]
    def __init__(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        face_offsets: Optional[np.ndarray] = ...,
        *,
        attributes: Optional[Dict[str, Attribute]] = ...,
        levels: int = ...,
        family: str = ...,
        order: str = ...,
        integers: Optional[np.ndarray] = ...,
        quantization: Optional[Dict[str, Any]] = ...,
        format: Optional[str] = ...,
        dropped: Optional[List[str]] = ...,
    ) -> None: ...
    @property
    def flat_faces(self) -> np.ndarray: ...
    def to_trimesh(self, **kwargs: Any) -> Any: ...

def compress(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    face_offsets: Optional[np.ndarray] = ...,
    bits: Optional[int] = ...,
    keep_order: bool = ...,
    decimals: Optional[int] = ...,
    effort: Optional[int] = ...,
    attributes: Optional[Dict[str, Union[Attribute, np.ndarray]]] = ...,
    threads: int = ...,
) -> bytes: ...
def decompress(
    data: Union[bytes, bytearray, memoryview],
    *,
    max_level: Optional[int] = ...,
    integers: bool = ...,
    threads: int = ...,
) -> Mesh: ...
def read(path: Union[str, os.PathLike]) -> Mesh: ...
def write(path: Union[str, os.PathLike], mesh: Mesh, **compress_args: Any) -> None: ...
def info(data: Union[bytes, bytearray, memoryview]) -> Dict[str, Any]: ...
