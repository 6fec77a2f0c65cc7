//! Small numerical helpers shared by element kernels: a scalar abstraction with exact
//! second-order forward-mode automatic differentiation ([`hyperdual`]) and the rotation
//! maps of SO(3) written once for any such scalar ([`rotation`]), and the `[T; 3]` vector
//! helpers used throughout the engine ([`vec3`]), and the bracket of a piecewise-linear
//! path ([`knot_bracket`]).

pub mod dual;
pub mod eigen3;
pub mod hyperdual;
pub mod rotation;
pub mod vec3;

pub use dual::{Dual, DualN};
pub use hyperdual::{HyperDual, HyperDual3, HyperDualN, Scalar, Seeded, HD_N};

/// Where step time `t` falls on a piecewise-linear path through knots at `times`
/// (increasing, not empty): `(i0, i1, w)` with the value `v[i0] + w·(v[i1] − v[i0])`. Before
/// the first knot the path holds its first value, after the last its last.
pub fn knot_bracket(times: &[f64], t: f64) -> (usize, usize, f64) {
    let k = times.partition_point(|&tk| tk < t);
    if k == 0 {
        return (0, 0, 0.0);
    }
    if k >= times.len() {
        let last = times.len() - 1;
        return (last, last, 0.0);
    }
    let (t0, t1) = (times[k - 1], times[k]);
    let w = if t1 > t0 {
        ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
    } else {
        1.0
    };
    (k - 1, k, w)
}

#[cfg(test)]
mod knot_tests {
    use super::knot_bracket;

    #[test]
    fn a_knot_bracket_holds_the_ends_and_interpolates_between() {
        let times = [0.0, 0.5, 1.0];
        assert_eq!(knot_bracket(&times, -1.0), (0, 0, 0.0));
        assert_eq!(knot_bracket(&times, 0.25), (0, 1, 0.5));
        assert_eq!(knot_bracket(&times, 0.5), (0, 1, 1.0));
        assert_eq!(knot_bracket(&times, 0.75), (1, 2, 0.5));
        assert_eq!(knot_bracket(&times, 2.0), (2, 2, 0.0));
    }
}
