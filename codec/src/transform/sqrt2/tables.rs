//! The frozen IR2W weights (SPEC.md 9.7), times 2^16: what `super::solve` (feature
//! `reference`) computes (a test checks it). Valences 3..=16; index = valence - 3.

/// Prediction weights of a corner's neighbours, j = 0..n-1 (they sum to 2^15).
pub const ALPHA: [&[i32]; 14] = [
    &[25844, 25843, -18919],
    &[24576, 24576, -8192, -8192],
    &[21366, 21365, 896, -11755, 896],
    &[18383, 18383, 5461, -7460, -7460, 5461],
    &[15941, 15941, 7462, -3111, -7816, -3111, 7462],
    &[13985, 13985, 8192, 0, -5793, -5793, 0, 8192],
    &[12413, 12411, 8307, 2020, -3509, -5692, -3509, 2020, 8307],
    &[
        11129, 11131, 8131, 3277, -1577, -4577, -4577, -1577, 3277, 8131,
    ],
    &[
        10074, 10074, 7822, 4031, -93, -3242, -4416, -3242, -93, 4031, 7822,
    ],
    &[
        9193, 9191, 7460, 4462, 999, -1999, -3730, -3730, -1999, 999, 4462, 7460,
    ],
    &[
        8446, 8445, 7087, 4684, 1785, -945, -2882, -3581, -2882, -945, 1785, 4684, 7087,
    ],
    &[
        7805, 7805, 6723, 4773, 2341, -92, -2042, -3124, -3124, -2042, -92, 2341, 4773, 6723,
    ],
    &[
        7252, 7253, 6377, 4776, 2726, 583, -1283, -2549, -2997, -2549, -1283, 583, 2726, 4776, 6377,
    ],
    &[
        6772, 6772, 6053, 4724, 2988, 1108, -628, -1957, -2676, -2676, -1957, -628, 1108, 2988,
        4724, 6053,
    ],
];

/// Lifting weights for a face whose one extraordinary corner (p0) has the valence:
/// omega0, omega1 = omega3, omega2, omega4 = omega11, omega5 = omega10, omega6 = omega9,
/// omega7 = omega8 (omega11 = 0 at valence 3).
pub const OMEGA: [[i32; 7]; 14] = [
    [-12776, -12274, -11796, 4638, 2193, 2564, 2473],
    [-11995, -11995, -11995, 2516, 2516, 2516, 2516],
    [-11008, -11605, -12257, 1238, 2618, 2494, 2564],
    [-10246, -11254, -12443, 539, 2625, 2480, 2596],
    [-9625, -10978, -12581, 200, 2594, 2476, 2618],
    [-9093, -10771, -12688, 41, 2551, 2477, 2636],
    [-8624, -10615, -12772, -31, 2507, 2481, 2650],
    [-8203, -10495, -12841, -59, 2466, 2488, 2661],
    [-7822, -10402, -12897, -65, 2428, 2495, 2671],
    [-7475, -10328, -12945, -61, 2394, 2502, 2680],
    [-7157, -10269, -12986, -53, 2364, 2510, 2687],
    [-6864, -10221, -13021, -42, 2336, 2517, 2694],
    [-6594, -10182, -13052, -30, 2312, 2525, 2700],
    [-6344, -10149, -13079, -19, 2290, 2531, 2705],
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transform::sqrt2::solve;

    #[test]
    fn frozen_tables_are_the_solver_output() {
        let alpha = solve::alpha_table(crate::transform::sqrt2::TABLE_MAX);
        let omega = solve::omega_table(crate::transform::sqrt2::TABLE_MAX);
        assert_eq!(alpha.len(), ALPHA.len());
        for (n, (frozen, solved)) in ALPHA.iter().zip(&alpha).enumerate() {
            let frozen: Vec<i64> = frozen.iter().map(|&w| w as i64).collect();
            assert_eq!(&frozen, solved, "alpha, valence {}", n + 3);
            assert_eq!(frozen.len(), n + 3);
            // With the corner's own 1/2, every corner stencil sums to exactly one.
            assert_eq!(frozen.iter().sum::<i64>(), 1 << 15, "valence {}", n + 3);
        }
        for (n, (frozen, solved)) in OMEGA.iter().zip(&omega).enumerate() {
            let frozen = frozen.map(|w| w as i64);
            assert_eq!(&frozen, solved, "omega, valence {}", n + 3);
        }
    }
}
