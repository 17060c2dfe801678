//! One level's transform in either direction, for every family (SPEC.md 9). The
//! encoder's analysis and the decoder's synthesis both prepare a level here, from its
//! [`Family`] and [`Wavelet`], so which family runs which transform is decided in one
//! place.

use crate::topology::{Family, Level};
use crate::transform::phase::Phases;
use crate::transform::polar::{self, Disc, DiscTransform};
use crate::transform::sqrt2::{self, Plan};
use crate::transform::{analyse_with, synthesise_with, Phaser, StencilCache, Stencils, Wavelet};

/// What a hierarchy's levels are transformed with: everything but the level itself.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Scheme<'p> {
    /// The refinement the levels follow.
    pub family: Family,
    /// The wavelet.
    pub wavelet: Wavelet,
    /// Polar hierarchies: the poles, canonical numbers (empty otherwise).
    pub poles: &'p [u32],
    /// Polar hierarchies: the transform of the poles' discs (SPEC.md 9.9).
    pub disc: DiscTransform,
    /// The hierarchy's stencils made so far, where kept (the encoder's, on hierarchies
    /// that are not large).
    pub stencils: Option<&'p StencilCache>,
}

/// One level's transform, prepared once for its three axes.
pub(crate) enum LevelTransform<'a> {
    /// sqrt2-lazy (SPEC.md 9.6): each face point's prediction from the coarse values
    /// (which it keeps), with their phases (10.6) when asked for.
    Sqrt2Lazy {
        /// Per axis, per face.
        predictions: [Vec<i64>; 3],
        /// The predictions' phases.
        phases: Option<Phases>,
    },
    /// sqrt2-sym (9.8), and ir2w's analysis (9.7): the lifting plan.
    Sqrt2Plan(Plan<'a>),
    /// ir2w: one pass of its own each way, which builds no plan
    /// ([`sqrt2::ir2w_analyse`], [`sqrt2::ir2w_synthesise`]).
    Ir2w,
    /// Catmull-Clark and polar levels (9.2-9.5, 9.9, 9.11, 9.12).
    Cc {
        /// The wavelet.
        w: Wavelet,
        /// Its stencils on this level.
        stencils: Stencils,
        /// The poles' discs, which the polar transform codes first (analysis) or last
        /// (synthesis).
        discs: Vec<Disc>,
        /// The fine values the discs own (the Catmull-Clark steps leave them).
        owned: Vec<bool>,
        /// The discs' transform.
        disc: DiscTransform,
        /// Whether the level has no pole: only then do the predict-only transforms
        /// give phases (SPEC.md 10.6).
        phased: bool,
    },
}

impl<'a> LevelTransform<'a> {
    /// Prepares level `index` (0 = the coarsest) of a hierarchy coded with `scheme`, for
    /// either direction. `x` holds at least the level's coarse values (sqrt2-lazy predicts
    /// from them); with `phases`, sqrt2-lazy also finds its predictions' phases.
    pub(crate) fn new(
        scheme: &Scheme<'_>,
        level: &'a Level,
        index: usize,
        x: &[Vec<i64>; 3],
        phases: bool,
    ) -> LevelTransform<'a> {
        Self::with_stencils(scheme, level, index, x, phases, None)
    }

    /// [`LevelTransform::new`] with a Catmull-Clark level's [`Stencils`] for the
    /// scheme's wavelet made beforehand (`stencils`; made here if `None`).
    pub(crate) fn with_stencils(
        scheme: &Scheme<'_>,
        level: &'a Level,
        index: usize,
        x: &[Vec<i64>; 3],
        phases: bool,
        stencils: Option<Stencils>,
    ) -> LevelTransform<'a> {
        let w = scheme.wavelet;
        match scheme.family {
            Family::Sqrt2 => match w {
                Wavelet::Sqrt2Lazy => {
                    let (predictions, phases) = sqrt2::predictions_with(level, x, phases);
                    LevelTransform::Sqrt2Lazy {
                        predictions,
                        phases,
                    }
                }
                Wavelet::Ir2w => LevelTransform::Ir2w,
                _ => LevelTransform::Sqrt2Plan(Plan::new(level, w)),
            },
            Family::Cc | Family::Polar | Family::None => {
                let (discs, owned) = polar::discs(level, scheme.poles, index as u32, scheme.disc);
                LevelTransform::Cc {
                    w,
                    stencils: stencils.unwrap_or_else(|| match scheme.stencils {
                        Some(cache) => cache.stencils(index, level, w),
                        None => Stencils::new(level, w),
                    }),
                    discs,
                    owned,
                    disc: scheme.disc,
                    phased: scheme.poles.is_empty(),
                }
            }
        }
    }

    /// The phaser of a predict-only Catmull-Clark level without poles (lazy, interp4,
    /// interp6: SPEC.md 10.6), whose details the LEVL modes 6 and 9 read by phase.
    pub(crate) fn phaser(&self, level: &'a Level) -> Option<Phaser<'_>> {
        match self {
            LevelTransform::Cc {
                w,
                stencils,
                phased: true,
                ..
            } => Phaser::new(level, *w, stencils),
            _ => None,
        }
    }

    /// A Catmull-Clark level's stencils, taken out (`None` for the other families).
    pub(crate) fn into_stencils(self) -> Option<Stencils> {
        match self {
            LevelTransform::Cc { stencils, .. } => Some(stencils),
            _ => None,
        }
    }

    /// The phases sqrt2-lazy found with its predictions.
    pub(crate) fn phases(&self) -> Option<&Phases> {
        match self {
            LevelTransform::Sqrt2Lazy { phases, .. } => phases.as_ref(),
            _ => None,
        }
    }

    /// The phases sqrt2-lazy found with its predictions, taken out (the encoder keeps
    /// them for the level's coding).
    pub(crate) fn take_phases(&mut self) -> Option<Phases> {
        match self {
            LevelTransform::Sqrt2Lazy { phases, .. } => phases.take(),
            _ => None,
        }
    }

    /// A sqrt(2) level's tangent targets (SPEC.md 10.3) from its coarse values; `None`
    /// for the other families.
    pub(crate) fn tangent_targets(
        &self,
        level: &Level,
        coarse: &[Vec<i64>; 3],
    ) -> Option<Vec<[i64; 3]>> {
        match self {
            LevelTransform::Sqrt2Lazy { predictions, .. } => {
                Some(sqrt2::tangent_targets_from(level, coarse, predictions))
            }
            LevelTransform::Sqrt2Plan(plan) => Some(sqrt2::tangent_targets(level, plan, coarse)),
            LevelTransform::Ir2w => Some(sqrt2::tangent_targets_from(
                level,
                coarse,
                &sqrt2::predictions(level, coarse),
            )),
            LevelTransform::Cc { .. } => None,
        }
    }

    /// Analysis, in place: `x[k][..fine]` (`fine` = the level's fine vertex count) become
    /// the coarse values and the details.
    pub(crate) fn analyse(&self, level: &Level, fine: usize, x: &mut [Vec<i64>; 3]) {
        match self {
            LevelTransform::Sqrt2Lazy { predictions, .. } => {
                for (xs, pk) in x.iter_mut().zip(predictions) {
                    sqrt2::apply_predictions(&mut xs[..fine], level.nv, pk, true);
                }
            }
            LevelTransform::Sqrt2Plan(plan) => {
                for xs in x.iter_mut() {
                    plan.analyse(&mut xs[..fine]);
                }
            }
            LevelTransform::Ir2w => sqrt2::ir2w_analyse(level, x),
            LevelTransform::Cc {
                w,
                stencils,
                discs,
                owned,
                disc,
                ..
            } => {
                // (Without poles an interp4 or interp6 level runs its three axes at once.)
                if discs.is_empty()
                    && !owned.contains(&true)
                    && fine == level.fine_nv()
                    && stencils.lift_axes(level, *w, x, true)
                {
                    return;
                }
                for xs in x.iter_mut() {
                    for d in discs {
                        polar::analyse(d, *disc, &mut xs[..fine]);
                    }
                    analyse_with(level, *w, stencils, &mut xs[..fine], owned);
                }
            }
        }
    }

    /// Synthesis, in place: the exact inverse of [`LevelTransform::analyse`] on the
    /// level's coarse values and details `x`.
    pub(crate) fn synthesise(&self, level: &Level, x: &mut [Vec<i64>; 3]) {
        match self {
            LevelTransform::Sqrt2Lazy { predictions, .. } => {
                for (xs, pk) in x.iter_mut().zip(predictions) {
                    sqrt2::apply_predictions(xs, level.nv, pk, false);
                }
            }
            LevelTransform::Sqrt2Plan(plan) => {
                for xs in x.iter_mut() {
                    plan.synthesise(xs);
                }
            }
            LevelTransform::Ir2w => sqrt2::ir2w_synthesise(level, x),
            LevelTransform::Cc {
                w,
                stencils,
                discs,
                owned,
                disc,
                ..
            } => {
                if discs.is_empty() && !owned.contains(&true) && stencils.lift_axes(level, *w, x, false) {
                    return;
                }
                for xs in x.iter_mut() {
                    synthesise_with(level, *w, stencils, xs, owned);
                    for d in discs.iter().rev() {
                        polar::synthesise(d, *disc, xs);
                    }
                }
            }
        }
    }
}
