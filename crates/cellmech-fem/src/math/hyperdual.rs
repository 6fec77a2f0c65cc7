//! Second-order forward-mode automatic differentiation.
//!
//! A [`HyperDual`] carries a value `v`, its gradient `g = ∂v/∂x` and its Hessian
//! `H = ∂²v/∂x²` with respect to [`HD_N`] = 12 independent variables (one two-node beam
//! element: 2 × (3 translations + 3 rotations)). The Hessian is stored packed (upper
//! triangle, row by row: 78 numbers), so one value is 91 `f64` on the stack and never
//! allocates. Arithmetic follows the product and chain rules exactly:
//!
//! - `(a·b)  = (aᵥbᵥ, aᵥ∇b + bᵥ∇a, aᵥH_b + bᵥH_a + ∇a∇bᵀ + ∇b∇aᵀ)`
//! - `f(a)  = (f(aᵥ), f′(aᵥ)∇a, f′(aᵥ)H_a + f″(aᵥ)∇a∇aᵀ)`
//!
//! so a function written once over the [`Scalar`] trait returns its energy with `f64` and
//! its energy, exact gradient (residual) and exact Hessian (tangent) with [`HyperDual`].

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Number of independent variables of a [`HyperDual`].
pub const HD_N: usize = 12;
/// Packed length of the symmetric Hessian, `N(N+1)/2`.
const HD_H: usize = HD_N * (HD_N + 1) / 2;

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

/// A value with its exact gradient and Hessian with respect to [`HD_N`] variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HyperDual {
    /// Value.
    pub v: f64,
    /// Gradient `∂v/∂xᵢ`.
    pub g: [f64; HD_N],
    /// Packed upper triangle of `∂²v/∂xᵢ∂xⱼ` (row-major, `i ≤ j`).
    h: [f64; HD_H],
}

impl HyperDual {
    /// The independent variable number `index` (< [`HD_N`]) with value `v`.
    pub fn variable(index: usize, v: f64) -> Self {
        let mut x = Self::constant(v);
        if let Some(g) = x.g.get_mut(index) {
            *g = 1.0;
        }
        x
    }

    /// Hessian entry `∂²v/∂xᵢ∂xⱼ`.
    pub fn hessian(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        // Row i of the packed triangle starts at Σ_{r<i} (N − r) = iN − i(i−1)/2.
        self.h[i * HD_N - i * (i + 1) / 2 + j]
    }

    /// Writes the full Hessian row-major into `out` (`HD_N × HD_N` entries).
    pub fn write_hessian(&self, out: &mut [f64]) {
        let mut k = 0;
        for i in 0..HD_N {
            for j in i..HD_N {
                out[i * HD_N + j] = self.h[k];
                out[j * HD_N + i] = self.h[k];
                k += 1;
            }
        }
    }
}

impl Scalar for HyperDual {
    fn constant(v: f64) -> Self {
        HyperDual {
            v,
            g: [0.0; HD_N],
            h: [0.0; HD_H],
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
        for i in 0..HD_N {
            let gi = d2f * self.g[i];
            for j in i..HD_N {
                r.h[k] = df * self.h[k] + gi * self.g[j];
                k += 1;
            }
        }
        for i in 0..HD_N {
            r.g[i] = df * self.g[i];
        }
        r
    }
}

/// The operations every forward-mode scalar derives the same way from its value field `v`,
/// its `Mul<f64>` and its [`Scalar::recip`]: `−a`, `a / b`, `a + c`, `a − c`.
macro_rules! derived_scalar_ops {
    ($t:ty) => {
        impl std::ops::Neg for $t {
            type Output = Self;
            #[inline]
            fn neg(self) -> Self {
                self * -1.0
            }
        }

        impl std::ops::Div for $t {
            type Output = Self;
            #[inline]
            fn div(self, b: Self) -> Self {
                self * $crate::math::Scalar::recip(b)
            }
        }

        impl std::ops::Add<f64> for $t {
            type Output = Self;
            #[inline]
            fn add(mut self, c: f64) -> Self {
                self.v += c;
                self
            }
        }

        impl std::ops::Sub<f64> for $t {
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

derived_scalar_ops!(HyperDual);

impl Add for HyperDual {
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

impl Sub for HyperDual {
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

impl Mul for HyperDual {
    type Output = Self;
    #[inline]
    fn mul(self, b: Self) -> Self {
        let a = self;
        let mut r = HyperDual::constant(a.v * b.v);
        let mut k = 0;
        for i in 0..HD_N {
            let (agi, bgi) = (a.g[i], b.g[i]);
            for j in i..HD_N {
                r.h[k] = a.v * b.h[k] + b.v * a.h[k] + agi * b.g[j] + bgi * a.g[j];
                k += 1;
            }
        }
        for i in 0..HD_N {
            r.g[i] = a.v * b.g[i] + b.v * a.g[i];
        }
        r
    }
}

impl Mul<f64> for HyperDual {
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
