//! Coding one refinement level's details (SPEC.md 10): the edge points' details, then the
//! face points', each as three values with integer models chosen by class, slot, the
//! previous value's magnitude and the magnitudes of the same slot at the neighbours.

pub mod fit;

mod correction;
mod frames;
mod models;
mod read;
mod write;

use correction::*;
use frames::*;
use models::*;

pub use models::LevelModels;
pub use read::{decode, BESIDE_MIN};
pub use write::encode;

use crate::entropy::{class_of, Decoder, Encoder, IntModel};

use crate::error::{Error, Result};

use crate::topology::{Family, Level};

use crate::transform::phase::{phase, Phases, FRAC_DIV};

/// Largest magnitude of a lifted value or detail (SPEC.md 9.3).
pub const MAX_LIFTED: i64 = (1 << 52) - 1;

/// Magnitude of a vertex with no detail (base vertices).
pub const UNKNOWN: u8 = 255;

/// Detail `i`'s phases on the three axes.
fn phases_at(p: &Phases, i: usize) -> [u8; 3] {
    [p.codes[0][i], p.codes[1][i], p.codes[2][i]]
}

/// Detail `i`'s fractions on the three axes (SPEC.md 10.9).
fn fracs_at(p: &Phases, i: usize) -> [i16; 3] {
    [p.fracs[0][i], p.fracs[1][i], p.fracs[2][i]]
}

/// Mode 9's mask bit for joint rounding: each correction rounded together with the
/// prediction's fraction, the value phased by that sum's remainder (SPEC.md 10.9).
const JOINT: u8 = 0x40;

/// How mode 9 rounds its corrections (SPEC.md 10.9).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Rounding {
    /// Apart from the prediction, the value phased by the prediction's phase.
    Apart,
    /// With the prediction's fraction, the value phased by their sum's phase.
    Joint,
}

/// The mode byte's unbinned flag: every value of the level is coded with the shared
/// model of its class and slot (or phase bin) rather than a model of its neighbour bin
/// (SPEC.md 10.1), for levels whose details hardly depend on their neighbours' sizes.
const UNBINNED: u8 = 0x80;

/// The mode byte's zero-slot flags, slot s at bit `ZERO_SHIFT + s`: the slots whose
/// coded values are all 0 at the level and left out of its stream (SPEC.md 10.1), as a
/// terrain grid's x and y, a flat mesh's z.
const ZERO_SLOTS: u8 = 0x70;

const ZERO_SHIFT: u32 = 4;

/// A LEVL payload's mode (SPEC.md 10.1): its first byte, without the unbinned flag and
/// the zero-slot flags; `None` for an empty payload.
pub fn mode_of(payload: &[u8]) -> Option<u8> {
    payload.first().map(|b| b & !(UNBINNED | ZERO_SLOTS))
}

/// A LEVL payload's zero-slot flags (SPEC.md 10.1): bit s set when slot s's values are
/// all 0 and not coded.
pub fn zero_slots(payload: &[u8]) -> u8 {
    payload
        .first()
        .map_or(0, |&b| (b & ZERO_SLOTS) >> ZERO_SHIFT)
}

/// Whether a LEVL payload is unbinned (SPEC.md 10.1).
pub fn unbinned(payload: &[u8]) -> bool {
    payload.first().is_some_and(|b| b & UNBINNED != 0)
}

/// Whether a LEVL payload is in mode 9 with joint rounding (SPEC.md 10.9).
pub fn joint(payload: &[u8]) -> bool {
    mode_of(payload) == Some(9) && payload.get(1).is_some_and(|m| m & JOINT != 0)
}

/// Whether a LEVL payload's mode reads its predictions' phases (modes 6 and 9, SPEC.md
/// 10.6, 10.9): the decoder makes them before it reads the level.
pub fn reads_phases(payload: &[u8]) -> bool {
    matches!(mode_of(payload), Some(6 | 9))
}

/// Whether a LEVL payload's mode reads tangent targets (modes 2 and 7, SPEC.md 10.3,
/// 10.7).
pub fn reads_targets(payload: &[u8]) -> bool {
    matches!(mode_of(payload), Some(2 | 7))
}

/// Whether a LEVL payload is in a rotated mode (4 or 5, SPEC.md 10.5).
pub fn rotated(payload: &[u8]) -> bool {
    matches!(mode_of(payload), Some(4 | 5))
}

/// Which of a level's details a sample holds (the encoder's mode trials, not part of the
/// format): all, or every `stride`-th block of [`SAMPLE_BLOCK`] details.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Sample {
    All,
    Blocks(usize),
}

const SAMPLE_BLOCK: usize = 64;
/// A sample holds at least every this many-th block...
const SAMPLE_STRIDE: usize = 8;
/// ... and on a larger level about this many details: enough to rank the modes (at
/// 2,400 details a mode 6 % larger on the whole level ranked first).
const SAMPLE_DETAILS: usize = 8_192;
/// A level of fewer than `2 * SAMPLE_DETAILS` details samples every `n / SMALL_SAMPLE`-th
/// block, but at least every second and at most every [`SAMPLE_STRIDE`]-th: half the
/// level's details or at least this many, denser than a large level's sample (fewer
/// than 2,400 details misrank modes).
const SMALL_SAMPLE: usize = 4_096;

impl Sample {
    /// The sample of a level of `nd` details.
    fn of(nd: usize) -> Sample {
        if nd < 2 * SAMPLE_DETAILS {
            return Sample::Blocks((nd / SMALL_SAMPLE).clamp(2, SAMPLE_STRIDE));
        }
        Sample::Blocks((nd / SAMPLE_DETAILS).max(SAMPLE_STRIDE))
    }

    /// Whether detail `i` is in the sample.
    fn has(self, i: usize) -> bool {
        match self {
            Sample::All => true,
            Sample::Blocks(stride) => (i / SAMPLE_BLOCK) % stride == 0,
        }
    }
}

/// What [`encode`] makes once per level for the modes that read it.
#[derive(Default)]
struct Prepared {
    /// The details' normal frames, for the normal-frame and rotated modes.
    normals: Vec<NormalFrame>,
    /// The rotated modes' frames (normals included), per detail.
    frames: RotFrames,
    /// Modes 8 and 9's correction numerators, per detail (from the level's one set of
    /// weights).
    corrections: Vec<[i64; 3]>,
}

/// How a level's details are coded (SPEC.md 10.2, 10.3).
#[derive(Clone, Copy)]
enum Mode<'a> {
    /// x, y, z as they are.
    Plain,
    /// In the coarse normal's frame.
    Framed,
    /// In the normal's frame, less each detail's target's tangential part.
    Tangent(&'a [[i64; 3]]),
    /// Rotated into the orthonormal frame of the normal and the coarse edge or face
    /// diagonal.
    Rotated,
    /// Rotated, and an interior edge point's tangential values less eighths `(a, b)` of
    /// its faces' offset.
    Shifted(u8, u8),
    /// x, y, z signed and modelled by their predictions' phases.
    Phased,
    /// Mode 2 with the values after the first shifted by their expected parts and
    /// phased.
    TangentPhased(&'a [[i64; 3]]),
    /// x, y, z less weighted sums of the level's earlier details nearby (Catmull-Clark
    /// levels).
    Corrected(Weights),
    /// Mode 8's values, phased as mode 6's; with the joint flag, each correction
    /// rounded with the prediction's fraction and the value phased by their sum.
    CorrectedPhased(Weights, Rounding),
}

/// Where a level's phases come from in the decoder (SPEC.md 10.6).
pub enum Phasing<'a> {
    /// Every detail's, known before the level is read (sqrt2-lazy: from the coarse
    /// values).
    Ready(&'a Phases),
    /// A Catmull-Clark level of a predict-only transform: the edge points' from the
    /// coarse values, the face points' once the edge points are read. The decoder then
    /// synthesises the level as it reads it: [`decode`] leaves the fine values, not the
    /// details.
    Cc(&'a crate::transform::Phaser<'a>),
}

impl Mode<'_> {
    /// The level's mode bytes: the mode, and mode 5's shift weights or mode 8 and 9's
    /// weights.
    fn bytes(self) -> Vec<u8> {
        match self {
            Mode::Shifted(a, b) => vec![5, a << 4 | b],
            Mode::Corrected(w) | Mode::CorrectedPhased(w, _) => {
                let joint = matches!(self, Mode::CorrectedPhased(_, Rounding::Joint));
                let mut out = vec![self.byte(), if joint { JOINT } else { 0 }];
                for (j, p) in w.iter().flatten().enumerate() {
                    if *p != [0; NFEAT] {
                        out[1] |= 1 << j;
                        out.extend(p.map(|v| v as u8));
                    }
                }
                out
            }
            _ => vec![self.byte()],
        }
    }

    fn byte(self) -> u8 {
        match self {
            Mode::Plain => 0,
            Mode::Framed => 1,
            Mode::Tangent(_) => 2,
            Mode::Rotated => 4,
            Mode::Shifted(..) => 5,
            Mode::Phased => 6,
            Mode::TangentPhased(_) => 7,
            Mode::Corrected(_) => 8,
            Mode::CorrectedPhased(..) => 9,
        }
    }

    /// Modes 6, 7 and 9, whose values are modelled by their phases.
    fn phased(self) -> bool {
        matches!(
            self,
            Mode::Phased | Mode::TangentPhased(_) | Mode::CorrectedPhased(..)
        )
    }

    fn framed(self) -> bool {
        !matches!(
            self,
            Mode::Plain | Mode::Phased | Mode::Corrected(_) | Mode::CorrectedPhased(..)
        )
    }

    /// What is subtracted from detail `i` before coding it in frame `fr`.
    fn offset(self, i: usize, fr: Option<(usize, [i64; 3])>) -> Option<[i64; 3]> {
        match (self, fr) {
            (Mode::Tangent(t) | Mode::TangentPhased(t), Some((_, n))) => Some(tangential(t[i], n)),
            _ => None,
        }
    }
}

/// `a + b` per component, `None` on overflow (see [`in_range`]).
fn plus(a: [i64; 3], b: [i64; 3]) -> Option<[i64; 3]> {
    Some([
        a[0].checked_add(b[0])?,
        a[1].checked_add(b[1])?,
        a[2].checked_add(b[2])?,
    ])
}

/// A decoded detail within the bound of SPEC.md 9.3, else a corrupt level.
fn in_range(d: Option<[i64; 3]>) -> Result<[i64; 3]> {
    d.filter(|d| d.iter().all(|v| v.abs() <= MAX_LIFTED))
        .ok_or_else(|| Error::corrupt("LEVL", "detail out of range"))
}

#[cfg(test)]
mod tests;
