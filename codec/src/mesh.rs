//! The integer mesh every stage works on: positions on an integer grid and polygonal
//! faces of any degree >= 3, stored flat.

use crate::error::{Error, Result};

/// Largest magnitude of an integer coordinate: 2^44 - 1 (SPEC.md 3.1). It leaves 19 bits of
/// headroom in `i64` for the sums of weighted neighbours the transforms accumulate.
pub const MAX_COORD: i64 = (1 << 44) - 1;

/// Bits of [`MAX_COORD`].
pub const COORD_BITS: u32 = 44;

/// A polygon mesh with integer positions.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Mesh {
    /// One integer position per vertex.
    pub positions: Vec<[i64; 3]>,
    /// `faces[face_starts[f]..face_starts[f + 1]]` are face `f`'s vertex indices, in
    /// order around the face. `face_starts` has one more entry than there are faces.
    pub face_starts: Vec<u32>,
    /// All faces' vertex indices, concatenated.
    pub faces: Vec<u32>,
    /// Binary float positions finer than their grid (SPEC.md 3.2): per vertex and axis,
    /// the value's IEEE 754 bits (binary32 in the low 32 bits), from which `positions`
    /// hold the integers on the grid. Empty when every value is its integer times the
    /// grid step (decimal and grid quantisation, and floats that fit one grid).
    pub floats: Vec<[u64; 3]>,
}

impl Mesh {
    /// An empty mesh.
    pub fn new() -> Self {
        Mesh {
            positions: Vec::new(),
            face_starts: vec![0],
            faces: Vec::new(),
            floats: Vec::new(),
        }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.face_starts.len().saturating_sub(1)
    }

    /// Number of face corners (the sum of face degrees).
    pub fn corner_count(&self) -> usize {
        self.faces.len()
    }

    /// Face `f`'s vertex indices.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.faces[self.face_starts[f] as usize..self.face_starts[f + 1] as usize]
    }

    /// Iterates over the faces.
    pub fn iter_faces(&self) -> impl Iterator<Item = &[u32]> + '_ {
        self.face_starts
            .windows(2)
            .map(move |w| &self.faces[w[0] as usize..w[1] as usize])
    }

    /// Appends a face.
    pub fn push_face(&mut self, corners: &[u32]) {
        if self.face_starts.is_empty() {
            self.face_starts.push(0);
        }
        self.faces.extend_from_slice(corners);
        self.face_starts.push(self.faces.len() as u32);
    }

    /// Checks the invariants every stage relies on: face structure consistent, every
    /// face has at least 3 corners, every index is in range, every coordinate is within
    /// [`MAX_COORD`].
    pub fn validate(&self) -> Result<()> {
        if self.face_starts.first() != Some(&0)
            || self.face_starts.last().map(|&e| e as usize) != Some(self.faces.len())
            || self.face_starts.windows(2).any(|w| w[1] < w[0])
        {
            return Err(Error::InvalidMesh("face table is inconsistent".into()));
        }
        if !self.floats.is_empty() && self.floats.len() != self.positions.len() {
            return Err(Error::InvalidMesh(format!(
                "{} float values for {} vertices",
                self.floats.len(),
                self.positions.len()
            )));
        }
        if self.positions.len() > u32::MAX as usize {
            return Err(Error::InvalidMesh("more than 2^32 - 1 vertices".into()));
        }
        for (f, face) in self.iter_faces().enumerate() {
            if face.len() < 3 {
                return Err(Error::InvalidMesh(format!(
                    "face {} has {} corners; faces need at least 3",
                    f + 1,
                    face.len()
                )));
            }
            if let Some(&i) = face.iter().find(|&&i| i as usize >= self.positions.len()) {
                return Err(Error::InvalidMesh(format!(
                    "face {} refers to vertex {} but there are only {} vertices",
                    f + 1,
                    i as u64 + 1,
                    self.positions.len()
                )));
            }
        }
        if let Some((v, p)) = self
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| p.iter().any(|c| c.abs() > MAX_COORD))
        {
            return Err(Error::Range(format!(
                "vertex {} has coordinate {:?} outside the codec's range of +-(2^{} - 1)",
                v + 1,
                p,
                COORD_BITS
            )));
        }
        Ok(())
    }
}
