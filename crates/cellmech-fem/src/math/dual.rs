//! First-order forward-mode automatic differentiation: a value and its gradient with
//! respect to `N` variables, for kernels written over [`Scalar`] whose residual is wanted
//! without the tangent (the Hessian of a [`super::HyperDual`] is 45 of its 55 numbers, and
//! its products cost about five times as much, so a residual-only evaluation with [`Dual`]
//! is several times cheaper).
//!
//! - `(a·b) = (aᵥbᵥ, aᵥ∇b + bᵥ∇a)`, `f(a) = (f(aᵥ), f′(aᵥ)∇a)`.

use std::ops::{Add, Mul, Sub};

use super::hyperdual::{derived_scalar_ops, Scalar, Seeded, HD_N};

/// The dual number of the beam kernel: [`HD_N`] variables.
pub type Dual = DualN<HD_N>;

/// A value with its exact gradient with respect to `N` variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DualN<const N: usize> {
    /// Value.
    pub v: f64,
    /// Gradient `∂v/∂xᵢ`.
    pub g: [f64; N],
}

impl<const N: usize> DualN<N> {
    /// The independent variable number `index` (< `N`) with value `v`.
    pub fn variable(index: usize, v: f64) -> Self {
        let mut x = Self::constant(v);
        if let Some(g) = x.g.get_mut(index) {
            *g = 1.0;
        }
        x
    }
}

impl<const N: usize> Scalar for DualN<N> {
    #[inline]
    fn constant(v: f64) -> Self {
        DualN { v, g: [0.0; N] }
    }
    #[inline]
    fn value(&self) -> f64 {
        self.v
    }
    #[inline]
    fn chain(self, f: f64, df: f64, _d2f: f64) -> Self {
        let mut r = self;
        r.v = f;
        for x in r.g.iter_mut() {
            *x *= df;
        }
        r
    }
}

impl<const N: usize> Seeded for DualN<N> {
    type Three = DualN<3>;
    #[inline]
    fn variable(index: usize, v: f64) -> Self {
        DualN::variable(index, v)
    }
    #[inline]
    fn variable3(index: usize, v: f64) -> DualN<3> {
        DualN::variable(index, v)
    }
    #[inline]
    fn embed3(x: DualN<3>, first: usize) -> Self {
        let mut r = Self::constant(x.v);
        r.g[first..first + 3].copy_from_slice(&x.g);
        r
    }
}

derived_scalar_ops!([const N: usize] DualN<N>);

impl<const N: usize> Add for DualN<N> {
    type Output = Self;
    #[inline]
    fn add(mut self, b: Self) -> Self {
        self.v += b.v;
        for (x, y) in self.g.iter_mut().zip(&b.g) {
            *x += y;
        }
        self
    }
}

impl<const N: usize> Sub for DualN<N> {
    type Output = Self;
    #[inline]
    fn sub(mut self, b: Self) -> Self {
        self.v -= b.v;
        for (x, y) in self.g.iter_mut().zip(&b.g) {
            *x -= y;
        }
        self
    }
}

impl<const N: usize> Mul for DualN<N> {
    type Output = Self;
    #[inline]
    fn mul(self, b: Self) -> Self {
        let mut r = Self::constant(self.v * b.v);
        for i in 0..N {
            r.g[i] = self.v * b.g[i] + b.v * self.g[i];
        }
        r
    }
}

impl<const N: usize> Mul<f64> for DualN<N> {
    type Output = Self;
    #[inline]
    fn mul(mut self, c: f64) -> Self {
        self.v *= c;
        for x in self.g.iter_mut() {
            *x *= c;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::HyperDual;

    /// A function exercising every operation and the chain rule (sqrt, recip).
    fn f<T: Scalar>(x: &[T; HD_N]) -> T {
        let a = x[0] * x[1] + x[2] * 3.0 - x[3] / (x[4] + 2.0);
        let b = (x[5] * x[5] + x[6] * x[6] + 1.0).sqrt();
        let c = -(x[7] - x[8]) * (x[2] + x[1] * x[6] + 3.0).recip();
        a * b + c - 0.5
    }

    #[test]
    fn dual_gradient_equals_the_hyperdual_gradient() {
        let point: [f64; HD_N] = std::array::from_fn(|i| 0.3 + 0.17 * i as f64);
        let d = f(&std::array::from_fn(|i| Dual::variable(i, point[i])));
        let h = f(&std::array::from_fn(|i| HyperDual::variable(i, point[i])));
        assert_eq!(d.v, h.v);
        for i in 0..HD_N {
            assert!(
                (d.g[i] - h.g[i]).abs() <= 1e-15 * h.g[i].abs().max(1.0),
                "{i}"
            );
        }
        // And a finite difference of the plain value, so that both are right.
        for i in 0..HD_N {
            let mut up = point;
            let mut down = point;
            up[i] += 1e-6;
            down[i] -= 1e-6;
            let fd = (f(&up) - f(&down)) / 2e-6;
            assert!(
                (fd - d.g[i]).abs() < 1e-7 * d.g[i].abs().max(1.0),
                "{i}: {fd} {}",
                d.g[i]
            );
        }
    }
}
