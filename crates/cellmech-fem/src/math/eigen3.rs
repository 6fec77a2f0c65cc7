//! The largest eigenvalue of a symmetric 3×3 matrix in closed form.
//!
//! Post-processing asks for the largest principal stretch at every Gauss point of every
//! element after every increment; an iterative eigensolver (nalgebra's QR sweeps) made that
//! 6 % of a whole analysis' time. The characteristic cubic of a symmetric matrix has three
//! real roots, found without iteration by the trigonometric method (Smith, "Eigenvalues of
//! a symmetric 3 × 3 matrix", Comm. ACM 4(4), 1961): with `q = tr A / 3`,
//! `p = √(tr((A − qI)²) / 6)` and `B = (A − qI) / p`, the roots are
//! `q + 2p cos(φ + 2πk/3)` with `φ = acos(det B / 2) / 3`, and `k = 0` is the largest.

use nalgebra::Matrix3;

/// Largest eigenvalue of the symmetric matrix `a` (only its lower triangle is read, except
/// by the fallback). Exact for a diagonal matrix; elsewhere within about 1e-13 of `‖a‖`:
/// where two eigenvalues (nearly) coincide the closed form loses digits, and nalgebra's
/// iterative solver is used instead.
pub fn max_symmetric_eigenvalue(a: &Matrix3<f64>) -> f64 {
    let (a00, a11, a22) = (a[(0, 0)], a[(1, 1)], a[(2, 2)]);
    let (a10, a21, a20) = (a[(1, 0)], a[(2, 1)], a[(2, 0)]);
    let off = a10 * a10 + a21 * a21 + a20 * a20;
    if off == 0.0 {
        return a00.max(a11).max(a22);
    }
    let q = (a00 + a11 + a22) / 3.0;
    let (b00, b11, b22) = (a00 - q, a11 - q, a22 - q);
    let p = ((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * off) / 6.0).sqrt();
    if p == 0.0 {
        return q;
    }
    // det((A − qI) / p) / 2
    let det = b00 * (b11 * b22 - a21 * a21) - a10 * (a10 * b22 - a21 * a20)
        + a20 * (a10 * a21 - b11 * a20);
    let r = 0.5 * det / (p * p * p);
    if !(r.abs() < 1.0 - NEAR_REPEATED) {
        // Two eigenvalues (nearly) coincide: acos loses half the digits near ±1 (an error
        // of about √ε·p), so the iterative solver takes these rare matrices.
        return a.symmetric_eigenvalues().max();
    }
    let phi = r.acos() / 3.0;
    q + 2.0 * p * phi.cos()
}

/// |r| beyond 1 − this: two eigenvalues (nearly) coincide. There the closed form's error in
/// φ is about ε / √(1 − r²) ≤ 1e-13, above the iterative solver's.
const NEAR_REPEATED: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(a: &Matrix3<f64>) -> f64 {
        a.symmetric_eigenvalues().max()
    }

    /// A symmetric matrix with the given eigenvalues in a rotated frame.
    fn with_eigenvalues(l: [f64; 3], angles: [f64; 3]) -> Matrix3<f64> {
        let r = nalgebra::Rotation3::from_euler_angles(angles[0], angles[1], angles[2]);
        let d = Matrix3::from_diagonal(&nalgebra::Vector3::new(l[0], l[1], l[2]));
        r.matrix() * d * r.matrix().transpose()
    }

    #[test]
    fn matches_the_iterative_eigensolver_on_rotated_spectra_including_repeated_ones() {
        let spectra = [
            [1.0, 2.0, 3.0],
            [0.25, 1.0, 7.5],
            [1.0, 1.0, 1.0 + 1e-9],  // nearly isotropic: the small-strain case
            [2.0, 2.0, 0.5],         // largest repeated
            [3.0, 0.5, 0.5],         // smallest repeated
            [1.0 + 1e-12, 1.0, 1.0], // round-off level anisotropy
            [1e-4, 1e4, 1.0],        // stretches of 1e-2 and 1e2
        ];
        let mut k = 0.0;
        for l in spectra {
            for _ in 0..20 {
                k += 1.0;
                let a = with_eigenvalues(l, [0.37 * k, 1.1 * k, -0.73 * k]);
                let expected = l[0].max(l[1]).max(l[2]);
                let got = max_symmetric_eigenvalue(&a);
                let scale = a.norm();
                assert!(
                    (got - expected).abs() <= 1e-13 * scale,
                    "{l:?}: got {got}, expected {expected}"
                );
                assert!((got - reference(&a)).abs() <= 1e-13 * scale);
            }
        }
    }

    #[test]
    fn a_diagonal_or_isotropic_matrix_is_exact() {
        let a = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.3, 4.0, -2.0));
        assert_eq!(max_symmetric_eigenvalue(&a), 4.0);
        let i = Matrix3::identity() * 2.5;
        assert_eq!(max_symmetric_eigenvalue(&i), 2.5);
    }
}
