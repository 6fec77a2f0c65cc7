//! Second-order forward-mode automatic differentiation.
//!
//! A [`HyperDualN`] carries a value `v`, its gradient `g = ∂v/∂x` and its Hessian
//! `H = ∂²v/∂x²` with respect to `N` independent variables. The Hessian is stored packed
//! (upper triangle, row by row: `H = N(N+1)/2` numbers), so one value lives on the stack and
//! never allocates. Arithmetic follows the product and chain rules exactly:
//!
//! - `(a·b)  = (aᵥbᵥ, aᵥ∇b + bᵥ∇a, aᵥH_b + bᵥH_a + ∇a∇bᵀ + ∇b∇aᵀ)`
//! - `f(a)  = (f(aᵥ), f′(aᵥ)∇a, f′(aᵥ)H_a + f″(aᵥ)∇a∇aᵀ)`
//!
//! so a function written once over the [`Scalar`] trait returns its energy with `f64` and
//! its energy, exact gradient (residual) and exact Hessian (tangent) with a hyper-dual.
//!
//! The cost of one product grows like `N²`, so kernels differentiate with as few variables
//! as their energy really depends on. [`HyperDual`] has [`HD_N`] = 9: the two-node beam's
//! energy depends on its nodes' translations only through their difference (3) and on the
//! two nodal rotation vectors (3 + 3). A sub-expression that depends on three of the
//! variables only (the rotation matrix of one node) is evaluated in the three-variable
//! companion of [`Seeded`] and embedded afterwards, which is exact (the chain rule with
//! an identity block) and several times cheaper than carrying all nine through it.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Number of independent variables of a [`HyperDual`] (and a [`super::Dual`]).
pub const HD_N: usize = 9;
/// Packed length of the symmetric Hessian of a [`HyperDual`], `N(N+1)/2`.
pub const HD_H: usize = HD_N * (HD_N + 1) / 2;

/// The hyper-dual number of the beam kernel: [`HD_N`] variables.
pub type HyperDual = HyperDualN<HD_N, HD_H>;
/// A hyper-dual number with three variables (one nodal rotation vector).
pub type HyperDual3 = HyperDualN<3, 6>;

/// A real scalar for code written once and evaluated either plainly (`f64`) or with
/// automatic derivatives ([`HyperDual`]).
pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
{
    /// A constant (all derivatives zero).
    fn constant(v: f64) -> Self;
    /// The plain value.
    fn value(&self) -> f64;
    /// `f(self)` given `f`, `f′` and `f″` evaluated at `self.value()` (chain rule).
    fn chain(self, f: f64, df: f64, d2f: f64) -> Self;

    /// `√x` (`x > 0` for finite derivatives).
    fn sqrt(self) -> Self {
        let v = self.value().sqrt();
        self.chain(v, 0.5 / v, -0.25 / (v * v * v))
    }
    /// `1/x`.
    fn recip(self) -> Self {
        let v = self.value();
        self.chain(1.0 / v, -1.0 / (v * v), 2.0 / (v * v * v))
    }
}

/// A [`Scalar`] whose independent variables can be seeded, with a three-variable companion
/// type whose derivatives embed into it.
///
/// `embed3(variable3(i, v) ∘ …, first)` equals the same expression evaluated directly on
/// `variable(first + i, v)`: the companion's gradient and Hessian are copied into the rows
/// and columns `first..first + 3`, every other derivative being zero.
pub trait Seeded: Scalar {
    /// The three-variable companion (`f64` for `f64`).
    type Three: Scalar;
    /// The independent variable number `index` with value `v`.
    fn variable(index: usize, v: f64) -> Self;
    /// The companion's independent variable number `index` (< 3) with value `v`.
    fn variable3(index: usize, v: f64) -> Self::Three;
    /// A companion value as a function of the variables `first..first + 3`.
    fn embed3(x: Self::Three, first: usize) -> Self;
}

impl Scalar for f64 {
    #[inline]
    fn constant(v: f64) -> Self {
        v
    }
    #[inline]
    fn value(&self) -> f64 {
        *self
    }
    #[inline]
    fn chain(self, f: f64, _df: f64, _d2f: f64) -> Self {
        f
    }
    #[inline]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline]
    fn recip(self) -> Self {
        1.0 / self
    }
}

impl Seeded for f64 {
    type Three = f64;
    #[inline]
    fn variable(_index: usize, v: f64) -> Self {
        v
    }
    #[inline]
    fn variable3(_index: usize, v: f64) -> f64 {
        v
    }
    #[inline]
    fn embed3(x: f64, _first: usize) -> Self {
        x
    }
}

/// A value with its exact gradient and Hessian with respect to `N` variables (`H` must be
/// `N(N+1)/2`, checked when a value is made).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HyperDualN<const N: usize, const H: usize> {
    /// Value.
    pub v: f64,
    /// Gradient `∂v/∂xᵢ`.
    pub g: [f64; N],
    /// Packed upper triangle of `∂²v/∂xᵢ∂xⱼ` (row-major, `i ≤ j`).
    h: [f64; H],
}

impl<const N: usize, const H: usize> HyperDualN<N, H> {
    /// The independent variable number `index` (< `N`) with value `v`.
    pub fn variable(index: usize, v: f64) -> Self {
        let mut x = Self::constant(v);
        if let Some(g) = x.g.get_mut(index) {
            *g = 1.0;
        }
        x
    }

    /// Start of row `i` of the packed triangle: `Σ_{r<i} (N − r) = iN − i(i+1)/2 + i`.
    #[inline]
    const fn row_start(i: usize) -> usize {
        i * N - i * (i + 1) / 2 + i
    }

    /// Hessian entry `∂²v/∂xᵢ∂xⱼ`.
    pub fn hessian(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        self.h[Self::row_start(i) + j - i]
    }

    /// Writes the full Hessian row-major into `out` (`N × N` entries).
    pub fn write_hessian(&self, out: &mut [f64]) {
        let mut k = 0;
        for i in 0..N {
            for j in i..N {
                out[i * N + j] = self.h[k];
                out[j * N + i] = self.h[k];
                k += 1;
            }
        }
    }
}

impl<const N: usize, const H: usize> Scalar for HyperDualN<N, H> {
    #[inline]
    fn constant(v: f64) -> Self {
        const { assert!(H == N * (N + 1) / 2, "H must be N(N+1)/2") };
        HyperDualN {
            v,
            g: [0.0; N],
            h: [0.0; H],
        }
    }
    #[inline]
    fn value(&self) -> f64 {
        self.v
    }
    #[inline]
    fn chain(self, f: f64, df: f64, d2f: f64) -> Self {
        let mut r = self;
        r.v = f;
        let mut k = 0;
        for i in 0..N {
            let gi = d2f * self.g[i];
            for j in i..N {
                r.h[k] = df * self.h[k] + gi * self.g[j];
                k += 1;
            }
        }
        for i in 0..N {
            r.g[i] = df * self.g[i];
        }
        r
    }
}

impl<const N: usize, const H: usize> Seeded for HyperDualN<N, H> {
    type Three = HyperDual3;
    #[inline]
    fn variable(index: usize, v: f64) -> Self {
        HyperDualN::variable(index, v)
    }
    #[inline]
    fn variable3(index: usize, v: f64) -> HyperDual3 {
        HyperDual3::variable(index, v)
    }
    #[inline]
    fn embed3(x: HyperDual3, first: usize) -> Self {
        let mut r = Self::constant(x.v);
        r.g[first..first + 3].copy_from_slice(&x.g);
        let mut k = 0;
        for i in 0..3 {
            let row = Self::row_start(first + i);
            for j in i..3 {
                r.h[row + j - i] = x.h[k];
                k += 1;
            }
        }
        r
    }
}

/// The operations every forward-mode scalar derives the same way from its value field `v`,
/// its `Mul<f64>` and its [`Scalar::recip`]: `−a`, `a / b`, `a + c`, `a − c`.
/// `[generic parameters] type`.
macro_rules! derived_scalar_ops {
    ([$($generics:tt)*] $t:ty) => {
        impl<$($generics)*> std::ops::Neg for $t {
            type Output = Self;
            #[inline]
            fn neg(self) -> Self {
                self * -1.0
            }
        }

        impl<$($generics)*> std::ops::Div for $t {
            type Output = Self;
            #[inline]
            fn div(self, b: Self) -> Self {
                self * $crate::math::Scalar::recip(b)
            }
        }

        impl<$($generics)*> std::ops::Add<f64> for $t {
            type Output = Self;
            #[inline]
            fn add(mut self, c: f64) -> Self {
                self.v += c;
                self
            }
        }

        impl<$($generics)*> std::ops::Sub<f64> for $t {
            type Output = Self;
            #[inline]
            fn sub(mut self, c: f64) -> Self {
                self.v -= c;
                self
            }
        }
    };
}
pub(crate) use derived_scalar_ops;

derived_scalar_ops!([const N: usize, const H: usize] HyperDualN<N, H>);

impl<const N: usize, const H: usize> Add for HyperDualN<N, H> {
    type Output = Self;
    #[inline]
    fn add(mut self, b: Self) -> Self {
        self.v += b.v;
        for (x, y) in self.g.iter_mut().zip(&b.g) {
            *x += y;
        }
        for (x, y) in self.h.iter_mut().zip(&b.h) {
            *x += y;
        }
        self
    }
}

impl<const N: usize, const H: usize> Sub for HyperDualN<N, H> {
    type Output = Self;
    #[inline]
    fn sub(mut self, b: Self) -> Self {
        self.v -= b.v;
        for (x, y) in self.g.iter_mut().zip(&b.g) {
            *x -= y;
        }
        for (x, y) in self.h.iter_mut().zip(&b.h) {
            *x -= y;
        }
        self
    }
}

impl<const N: usize, const H: usize> Mul for HyperDualN<N, H> {
    type Output = Self;
    #[inline]
    fn mul(self, b: Self) -> Self {
        let a = self;
        let mut r = Self::constant(a.v * b.v);
        let mut k = 0;
        for i in 0..N {
            let (agi, bgi) = (a.g[i], b.g[i]);
            for j in i..N {
                r.h[k] = a.v * b.h[k] + b.v * a.h[k] + agi * b.g[j] + bgi * a.g[j];
                k += 1;
            }
        }
        for i in 0..N {
            r.g[i] = a.v * b.g[i] + b.v * a.g[i];
        }
        r
    }
}

impl<const N: usize, const H: usize> Mul<f64> for HyperDualN<N, H> {
    type Output = Self;
    #[inline]
    fn mul(mut self, c: f64) -> Self {
        self.v *= c;
        for x in self.g.iter_mut() {
            *x *= c;
        }
        for x in self.h.iter_mut() {
            *x *= c;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A function of three variables exercising every operation and the chain rule.
    fn f<T: Scalar>(x: &[T; 3]) -> T {
        let a = x[0] * x[1] + x[2] * 3.0 - x[1] / (x[0] + 2.0);
        let b = (x[2] * x[2] + x[0] * x[0] + 1.0).sqrt();
        a * b - (x[2] - x[1]).recip() * 0.3
    }

    #[test]
    fn an_embedded_three_variable_value_equals_the_direct_evaluation() {
        let p = [0.3, -0.7, 1.1];
        for first in 0..=HD_N - 3 {
            let direct = f(&std::array::from_fn(|i| {
                HyperDual::variable(first + i, p[i])
            }));
            let three = f(&std::array::from_fn(|i| HyperDual::variable3(i, p[i])));
            let embedded = HyperDual::embed3(three, first);
            assert_eq!(embedded.v, direct.v);
            for i in 0..HD_N {
                assert!((embedded.g[i] - direct.g[i]).abs() < 1e-15, "g{i}");
                for j in 0..HD_N {
                    let (e, d) = (embedded.hessian(i, j), direct.hessian(i, j));
                    assert!((e - d).abs() < 1e-14 * d.abs().max(1.0), "H{i}{j}: {e} {d}");
                }
            }
            // And the three-variable Hessian against finite differences of its gradient.
            let h = 1e-6;
            for j in 0..3 {
                let (mut up, mut down) = (p, p);
                up[j] += h;
                down[j] -= h;
                let gu = f(&std::array::from_fn(|i| HyperDual3::variable(i, up[i])));
                let gd = f(&std::array::from_fn(|i| HyperDual3::variable(i, down[i])));
                for i in 0..3 {
                    let fd = (gu.g[i] - gd.g[i]) / (2.0 * h);
                    assert!((fd - three.hessian(i, j)).abs() < 1e-7, "H{i}{j}");
                }
            }
        }
    }
}
