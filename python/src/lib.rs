//! The `subwave._subwave` extension module: the Rust library's coding, reading and
//! writing on numpy arrays. The `subwave` package (`subwave/__init__.py`) wraps it in
//! the documented API; every call here releases the GIL while it codes, reads or
//! writes, and every error is a `subwave.Error` (never a panic across into Python).

use numpy::{
    IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use subwave::{
    Attribute, Decimal, DecodeOptions, Domain, EncodeOptions, FloatWidth, Format, Limits, Mesh,
    Quantization, RawCoords, ValueType,
};

create_exception!(
    _subwave,
    Error,
    pyo3::exceptions::PyException,
    "Every error subwave reports; the message is the Rust library's."
);
create_exception!(
    _subwave,
    MeshFileError,
    Error,
    "A mesh file that cannot be read."
);
create_exception!(
    _subwave,
    InvalidMeshError,
    Error,
    "A mesh subwave cannot code: faces of fewer than 3 corners, indices out of range, NaN, values beyond the codec's range."
);
create_exception!(
    _subwave,
    CorruptError,
    Error,
    "A container that is cut, flipped, malformed or over the decoder's limits."
);
create_exception!(
    _subwave,
    UnsupportedError,
    Error,
    "A container or file feature this version does not support."
);
create_exception!(
    _subwave,
    FileError,
    Error,
    "A file that cannot be read or written."
);

/// The Python exception for a library error, with its message.
fn py_err(e: subwave::Error) -> PyErr {
    use subwave::Error as E;
    let msg = e.to_string();
    match e {
        E::Io(_) => FileError::new_err(msg),
        E::MeshFile(_) => MeshFileError::new_err(msg),
        E::InvalidMesh(_) | E::Range(_) => InvalidMeshError::new_err(msg),
        E::Unsupported(_) => UnsupportedError::new_err(msg),
        E::InvalidArgument(_) => pyo3::exceptions::PyValueError::new_err(msg),
        _ => CorruptError::new_err(msg),
    }
}

/// Positions as numpy gives them: integers, float32 or float64, shape (n, 3).
#[derive(FromPyObject)]
enum Vertices<'py> {
    Int(PyReadonlyArray2<'py, i64>),
    F32(PyReadonlyArray2<'py, f32>),
    F64(PyReadonlyArray2<'py, f64>),
}

impl Vertices<'_> {
    /// The coordinates as decimal numbers of `d` decimals: integers `n` stand for
    /// `n / 10^d`; a float must be the double nearest such a number (as text with at
    /// most `d` decimals reads), else an error.
    fn decimal(&self, d: u8) -> PyResult<RawCoords> {
        if d > subwave::MAX_DECIMALS {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "decimals must be at most {}",
                subwave::MAX_DECIMALS
            )));
        }
        let scale = 10f64.powi(d as i32);
        let of_f64 = |x: f64| -> PyResult<Decimal> {
            let m = (x * scale).round();
            let dec = Decimal {
                mantissa: m as i64,
                decimals: d,
            };
            if m.abs() < 9.0e18 && dec.to_f64() == x {
                Ok(dec)
            } else {
                Err(InvalidMeshError::new_err(format!(
                    "{x:?} is not a number of {d} decimals; leave decimals unset to code the floats exactly"
                )))
            }
        };
        let v: Vec<[Decimal; 3]> = match self.raw()? {
            RawCoords::Decimal(v) => v
                .into_iter()
                .map(|p| p.map(|m| Decimal { decimals: d, ..m }))
                .collect(),
            RawCoords::F32(v) => v
                .iter()
                .map(|p| {
                    Ok([
                        of_f64(p[0] as f64)?,
                        of_f64(p[1] as f64)?,
                        of_f64(p[2] as f64)?,
                    ])
                })
                .collect::<PyResult<_>>()?,
            RawCoords::F64(v) => v
                .iter()
                .map(|p| Ok([of_f64(p[0])?, of_f64(p[1])?, of_f64(p[2])?]))
                .collect::<PyResult<_>>()?,
        };
        Ok(RawCoords::Decimal(v))
    }

    /// The coordinates as the codec reads a file's: integers as decimals without
    /// decimals, floats bit for bit.
    fn raw(&self) -> PyResult<RawCoords> {
        fn rows<T: Copy + numpy::Element>(a: &PyReadonlyArray2<'_, T>) -> PyResult<Vec<[T; 3]>> {
            if a.shape()[1] != 3 {
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "vertices must have shape (n, 3), not {:?}",
                    a.shape()
                )));
            }
            let v = a.as_array();
            Ok(v.outer_iter().map(|r| [r[0], r[1], r[2]]).collect())
        }
        Ok(match self {
            Vertices::Int(a) => RawCoords::Decimal(
                rows(a)?
                    .into_iter()
                    .map(|p| {
                        p.map(|m| Decimal {
                            mantissa: m,
                            decimals: 0,
                        })
                    })
                    .collect(),
            ),
            Vertices::F32(a) => RawCoords::F32(rows(a)?),
            Vertices::F64(a) => RawCoords::F64(rows(a)?),
        })
    }
}

/// The integer mesh of `vertices` and faces (`faces` flat, face `i` from
/// `offsets[i]` to `offsets[i + 1]`), exactly or on the `bits` grid.
fn integer_mesh(
    raw: &RawCoords,
    faces: Vec<u32>,
    offsets: Vec<u32>,
    bits: Option<u8>,
) -> subwave::Result<(Mesh, Quantization)> {
    if offsets.first().is_some_and(|&o| o != 0)
        || offsets.windows(2).any(|w| w[0] > w[1])
        || offsets
            .last()
            .map_or(!faces.is_empty(), |&o| o as usize != faces.len())
    {
        return Err(subwave::Error::InvalidMesh(
            "face offsets must start at 0, never decrease and end at the number of indices".into(),
        ));
    }
    let (positions, q, floats) = subwave::integerize(raw, bits)?;
    let mesh = Mesh {
        positions,
        faces,
        face_starts: if offsets.len() > 1 {
            offsets
        } else {
            Vec::new()
        },
        floats,
        attributes: Vec::new(),
    };
    mesh.validate()?;
    Ok((mesh, q))
}

/// Compresses a mesh into a container (`bits`: Draco's grid instead of the exact
/// values; `keep_order`: the input's vertex and face order restored on decoding).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (vertices, faces, offsets, bits=None, keep_order=false, threads=1, decimals=None, effort=None, attributes=Vec::new()))]
fn compress<'py>(
    py: Python<'py>,
    vertices: Vertices<'py>,
    faces: PyReadonlyArray1<'py, u32>,
    offsets: PyReadonlyArray1<'py, u32>,
    bits: Option<u8>,
    keep_order: bool,
    threads: usize,
    decimals: Option<u8>,
    effort: Option<u8>,
    attributes: Vec<(GivenChannel<'py>, u8)>,
) -> PyResult<Bound<'py, PyBytes>> {
    let attributes = channels(attributes)?;
    if bits.is_some_and(|b| !(1..=30).contains(&b)) {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "bits must be between 1 and 30",
        ));
    }
    let raw = match decimals {
        Some(d) => vertices.decimal(d)?,
        None => vertices.raw()?,
    };
    let faces = faces.as_slice()?.to_vec();
    let offsets = offsets.as_slice()?.to_vec();
    let bytes = py
        .detach(|| {
            let (mut mesh, q) = integer_mesh(&raw, faces, offsets, bits)?;
            mesh.attributes = attributes;
            mesh.validate()?;
            let opts = EncodeOptions {
                keep_order,
                threads: threads.max(1),
                effort: effort.unwrap_or(subwave::DEFAULT_EFFORT),
                ..Default::default()
            };
            subwave::encode_to_vec(&mesh, &q, &opts).map(|e| e.bytes)
        })
        .map_err(py_err)?;
    Ok(PyBytes::new(py, &bytes))
}

/// A decoded or read mesh, as the package's `Mesh` is built from it.
type MeshParts<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    String,
    Vec<Channel<'py>>,
);

/// Values `p` (with float bits `f`) on `q` in the type they came in, `width` per row:
/// int64 for integers, float32 or float64 for binary floats (bit for bit), float64 for
/// decimals (the nearest), float32 for Draco's grid.
fn value_array<'py>(
    py: Python<'py>,
    p: &[[i64; 3]],
    f: &[[u64; 3]],
    q: &Quantization,
    width: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let n = p.len();
    Ok(match (*q, f.is_empty()) {
        (Quantization::Decimal { decimals: 0 }, _) => rows(p, width, |row, k| row[k])
            .into_pyarray(py)
            .reshape([n, width])?
            .into_any(),
        (
            Quantization::Float {
                width: FloatWidth::F32,
                ..
            }
            | Quantization::Grid { .. },
            _,
        ) => {
            let v = match (f.is_empty(), *q) {
                // The grid's `value_f32`, its step and origin taken out of the loop.
                (true, Quantization::Grid { origin, step, .. }) => {
                    rows(p, width, |row, k| (row[k] as f32) * step + origin[k])
                }
                (true, _) => rows(p, width, |row, k| q.value_f32(row[k], k)),
                (false, _) => rows(f, width, |row, k| f32::from_bits(row[k] as u32)),
            };
            v.into_pyarray(py).reshape([n, width])?.into_any()
        }
        _ => {
            let v = match f.is_empty() {
                true => rows(p, width, |row, k| q.value_f64(row[k], k)),
                false => rows(f, width, |row, k| f64::from_bits(row[k])),
            };
            v.into_pyarray(py).reshape([n, width])?.into_any()
        }
    })
}

/// The first `width` columns of every row of `rows`, one after the other, each made by
/// `value(row, column)`.
fn rows<R: Copy, T>(rows: &[[R; 3]], width: usize, value: impl Fn(&[R; 3], usize) -> T) -> Vec<T> {
    let mut out = Vec::with_capacity(rows.len() * width);
    match width {
        // Positions: a fixed inner loop the compiler unrolls.
        3 => out.extend(
            rows.iter()
                .flat_map(|r| [value(r, 0), value(r, 1), value(r, 2)]),
        ),
        _ => out.extend(rows.iter().flat_map(|r| (0..width).map(|k| value(r, k)))),
    }
    out
}

/// An attribute channel as the package's `Attribute` is built from it: name, domain,
/// type, values `(entries, width)`, corner indices (a corner channel's), quantisation,
/// names (a channel of names').
type Channel<'py> = (
    String,
    &'static str,
    &'static str,
    Bound<'py, PyAny>,
    Option<Bound<'py, PyAny>>,
    String,
    Vec<String>,
);

/// The names of [`ValueType`]s in Python, in the order of their codes.
const TYPE_NAMES: [&str; 9] = ["text", "f32", "f64", "i8", "u8", "i16", "u16", "i32", "u32"];

/// The values of `mesh` on `q` in the type they came in ([`value_array`]), with the
/// integers and the quantisation as JSON, and the attribute channels. The mesh's face
/// arrays become the package's without a copy.
fn parts<'py>(py: Python<'py>, mesh: Mesh, q: &Quantization) -> PyResult<MeshParts<'py>> {
    let n = mesh.vertex_count();
    let values = value_array(py, &mesh.positions, &mesh.floats, q, 3)?;
    let ints = PyArray1::from_slice(py, mesh.positions.as_flattened())
        .reshape([n, 3])?
        .into_any();
    let faces = mesh.faces.into_pyarray(py).into_any();
    let offsets = match mesh.face_starts.is_empty() {
        true => vec![0u32],
        false => mesh.face_starts,
    };
    let offsets = offsets.into_pyarray(py).into_any();
    let mut channels = Vec::with_capacity(mesh.attributes.len());
    for a in &mesh.attributes {
        let values = value_array(py, &a.values, &a.floats, &a.quantization, a.width as usize)?;
        // A corner channel's entries per corner; a list channel's lengths.
        let indices = match a.domain == Domain::Corner || a.is_list() {
            true => Some(a.indices.clone().into_pyarray(py).into_any()),
            false => None,
        };
        channels.push((
            a.name.clone(),
            a.domain.name(),
            TYPE_NAMES[a.value_type.code() as usize],
            values,
            indices,
            subwave::json::quantization(&a.quantization).to_string(),
            a.labels.clone(),
        ));
    }
    Ok((
        values,
        ints,
        faces,
        offsets,
        subwave::json::quantization(q).to_string(),
        channels,
    ))
}

/// An attribute channel given from Python: name, domain, type, values (padded to
/// three columns), corner indices, names.
type GivenChannel<'py> = (
    String,
    String,
    String,
    Vertices<'py>,
    Option<PyReadonlyArray1<'py, u32>>,
    Vec<String>,
);

/// The channels given from Python, their values exact as they came (integers as
/// integers, floats bit for bit), each `width` values per entry.
fn channels(given: Vec<(GivenChannel<'_>, u8)>) -> PyResult<Vec<Attribute>> {
    let bad = |m: String| pyo3::exceptions::PyValueError::new_err(m);
    given
        .into_iter()
        .map(|((name, domain, ty, values, indices, labels), width)| {
            let domain = match domain.as_str() {
                "vertex" => Domain::Vertex,
                "face" => Domain::Face,
                "corner" => Domain::Corner,
                "file" => Domain::File,
                d => {
                    return Err(bad(format!(
                        "attribute '{name}': domain '{d}' (vertex, face, corner or file)"
                    )))
                }
            };
            let value_type = TYPE_NAMES
                .iter()
                .position(|t| *t == ty)
                .and_then(|c| ValueType::from_code(c as u8))
                .ok_or_else(|| {
                    bad(format!(
                        "attribute '{name}': type '{ty}' (one of {})",
                        TYPE_NAMES.join(", ")
                    ))
                })?;
            let raw = values.raw()?;
            let (values, quantization, floats) = subwave::integerize(&raw, None).map_err(py_err)?;
            Ok(Attribute {
                name,
                domain,
                value_type,
                width,
                values,
                floats,
                quantization,
                indices: match indices {
                    Some(i) => i.as_slice()?.to_vec(),
                    None => Vec::new(),
                },
                labels,
            })
        })
        .collect()
}

/// Decompresses a container: the mesh's parts, then its levels, family and whether the
/// vertices are in the input's order.
#[pyfunction]
#[pyo3(signature = (data, max_level=None, threads=1))]
fn decompress<'py>(
    py: Python<'py>,
    data: &[u8],
    max_level: Option<u8>,
    threads: usize,
) -> PyResult<(MeshParts<'py>, u8, String, bool)> {
    let dec = py
        .detach(|| {
            subwave::decode(
                data,
                &DecodeOptions {
                    limits: Limits::default(),
                    max_level,
                    threads,
                },
            )
        })
        .map_err(py_err)?;
    let levels = max_level.map_or(dec.header.levels, |m| m.min(dec.header.levels));
    Ok((
        parts(py, dec.mesh, &dec.quantization)?,
        levels,
        dec.header.family.name().to_string(),
        dec.input_order,
    ))
}

/// Reads a mesh file (OBJ, PLY, OFF, STL) exactly: its parts, its format's name and
/// what it held that is not carried.
#[pyfunction]
fn read<'py>(py: Python<'py>, path: &str) -> PyResult<(MeshParts<'py>, String, Vec<String>)> {
    let loaded = py
        .detach(|| {
            let bytes = std::fs::read(path).map_err(|e| {
                subwave::Error::Io(std::io::Error::new(e.kind(), format!("{path}: {e}")))
            })?;
            subwave::load(&bytes, None)
        })
        .map_err(py_err)?;
    Ok((
        parts(py, loaded.mesh, &loaded.quantization)?,
        loaded.format.name().to_string(),
        loaded.dropped.into_iter().collect(),
    ))
}

/// Writes a mesh file, its format from the extension (`.obj`, `.ply`, `.off`, `.stl`):
/// the values exactly (PLY and STL in ASCII when binary floats cannot hold them).
#[pyfunction]
#[pyo3(signature = (path, vertices, faces, offsets, attributes=Vec::new()))]
fn write<'py>(
    py: Python<'py>,
    path: &str,
    vertices: Vertices<'py>,
    faces: PyReadonlyArray1<'py, u32>,
    offsets: PyReadonlyArray1<'py, u32>,
    attributes: Vec<(GivenChannel<'py>, u8)>,
) -> PyResult<()> {
    let attributes = channels(attributes)?;
    let raw = vertices.raw()?;
    let faces = faces.as_slice()?.to_vec();
    let offsets = offsets.as_slice()?.to_vec();
    py.detach(|| {
        let format = Format::from_path(path).ok_or_else(|| {
            subwave::Error::InvalidArgument(format!(
                "{path}: the extension names no mesh format (.obj, .ply, .off, .stl)"
            ))
        })?;
        let (mut mesh, q) = integer_mesh(&raw, faces, offsets, None)?;
        mesh.attributes = attributes;
        mesh.validate()?;
        let format = format.exact_for(&q);
        let mut out = Vec::new();
        subwave::write_mesh(&mut out, &mesh, &q, format)?;
        std::fs::write(path, out)
            .map_err(|e| subwave::Error::Io(std::io::Error::new(e.kind(), format!("{path}: {e}"))))
    })
    .map_err(py_err)
}

/// What `subwave info --json` prints of a container, as JSON text.
#[pyfunction]
fn info(py: Python<'_>, data: &[u8]) -> PyResult<String> {
    let info = py
        .detach(|| subwave::inspect(data, &Limits::default()))
        .map_err(py_err)?;
    Ok(subwave::json::info(&info).to_string())
}

#[pymodule]
fn _subwave(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("Error", py.get_type::<Error>())?;
    m.add("MeshFileError", py.get_type::<MeshFileError>())?;
    m.add("InvalidMeshError", py.get_type::<InvalidMeshError>())?;
    m.add("CorruptError", py.get_type::<CorruptError>())?;
    m.add("UnsupportedError", py.get_type::<UnsupportedError>())?;
    m.add("FileError", py.get_type::<FileError>())?;
    m.add("FORMAT_VERSION", subwave::FORMAT_VERSION)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(compress, m)?)?;
    m.add_function(wrap_pyfunction!(decompress, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(info, m)?)?;
    Ok(())
}
