//! `[T; 3]` vector helpers shared by the element, material and contact code.
//!
//! Plain arrays (not nalgebra vectors) because kernels store nodal data as `[f64; 3]` and
//! the beam evaluates the same kinematics over [`HyperDual`](super::HyperDual) numbers: the
//! products and sums are generic over any `Copy` number type with `+ − ×`. Every helper
//! evaluates left to right in component order (`a₀b₀ + a₁b₁ + a₂b₂`), so replacing a
//! hand-written expression of that form by the helper leaves results bit-identical.

use std::ops::{Add, Mul, Sub};

/// a + b.
#[inline]
pub fn add<T: Copy + Add<Output = T>>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// a − b.
#[inline]
pub fn sub<T: Copy + Sub<Output = T>>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a · b.
#[inline]
pub fn dot<T: Copy + Add<Output = T> + Mul<Output = T>>(a: &[T; 3], b: &[T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a × b.
#[inline]
pub fn cross<T: Copy + Sub<Output = T> + Mul<Output = T>>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// s a.
#[inline]
pub fn scale(a: &[f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// |a|.
#[inline]
pub fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// |b − a|.
#[inline]
pub fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    norm(&sub(b, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vec3_helpers_match_their_definitions() {
        let (a, b): ([f64; 3], [f64; 3]) = ([1.0, -2.0, 0.5], [0.3, 4.0, -1.0]);
        assert_eq!(add(&a, &b), [1.3, 2.0, -0.5]);
        assert_eq!(sub(&a, &b), [0.7, -6.0, 1.5]);
        assert_eq!(dot(&a, &b), 0.3 - 8.0 - 0.5);
        let c = cross(&a, &b);
        assert!(dot(&c, &a).abs() < 1e-14 && dot(&c, &b).abs() < 1e-14);
        assert_eq!(cross(&[1.0, 0.0, 0.0], &[0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(scale(&a, 2.0), [2.0, -4.0, 1.0]);
        assert_eq!(norm(&[3.0, 4.0, 12.0]), 13.0);
        assert_eq!(distance(&[1.0, 1.0, 1.0], &[4.0, 5.0, 13.0]), 13.0);
    }
}
