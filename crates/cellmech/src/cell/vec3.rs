//! Small 3-vector and rotation helpers used by the cell geometry (plain `[f64; 3]` by
//! value). The arithmetic is the engine's `math::vec3`; the rotations are cell-geometry
//! helpers.

use cellmech_fem::math::vec3 as v;

/// A 3-vector.
pub(crate) type V3 = [f64; 3];

/// A rotation matrix, rows first.
pub(crate) type M3 = [[f64; 3]; 3];

pub(crate) fn add(a: V3, b: V3) -> V3 {
    v::add(&a, &b)
}

pub(crate) fn sub(a: V3, b: V3) -> V3 {
    v::sub(&a, &b)
}

pub(crate) fn scale(a: V3, s: f64) -> V3 {
    v::scale(&a, s)
}

pub(crate) fn dot(a: V3, b: V3) -> f64 {
    v::dot(&a, &b)
}

pub(crate) fn cross(a: V3, b: V3) -> V3 {
    v::cross(&a, &b)
}

pub(crate) fn norm(a: V3) -> f64 {
    v::norm(&a)
}

pub(crate) fn distance(a: V3, b: V3) -> f64 {
    v::distance(&a, &b)
}

/// `a / |a|`; the caller guarantees `a ≠ 0`.
pub(crate) fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / norm(a))
}

/// Angle between two non-zero vectors, in `[0, π]` (robust near 0 and π).
pub(crate) fn angle(a: V3, b: V3) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b))
}

/// A unit vector perpendicular to the unit vector `u`, chosen deterministically (from the
/// coordinate axis least aligned with `u`).
pub(crate) fn any_perpendicular(u: V3) -> V3 {
    let abs = u.map(f64::abs);
    let axis = if abs[0] <= abs[1] && abs[0] <= abs[2] {
        [1.0, 0.0, 0.0]
    } else if abs[1] <= abs[2] {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    normalize(cross(u, axis))
}

/// `m · v`.
pub(crate) fn apply(m: &M3, v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// `a · b` for rotation matrices.
pub(crate) fn compose(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The identity matrix.
pub(crate) const IDENTITY: M3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Rotation matrix of the unit quaternion `(w, x, y, z)` (normalised here).
pub(crate) fn quaternion_matrix(q: [f64; 4]) -> M3 {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let [w, x, y, z] = q.map(|c| c / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// Rodrigues rotation of `v` about the unit `axis` by `angle` radians.
pub(crate) fn rotate_about(v: V3, axis: V3, angle: f64) -> V3 {
    let (s, c) = angle.sin_cos();
    add(
        add(scale(v, c), scale(cross(axis, v), s)),
        scale(axis, dot(axis, v) * (1.0 - c)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_matrix_is_a_rotation() {
        let m = quaternion_matrix([0.3, -0.5, 0.7, 0.2]);
        let mt: M3 = std::array::from_fn(|i| std::array::from_fn(|j| m[j][i]));
        let p = compose(&m, &mt);
        for i in 0..3 {
            for j in 0..3 {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((p[i][j] - e).abs() < 1e-14);
            }
        }
        let det = dot(m[0], cross(m[1], m[2]));
        assert!((det - 1.0).abs() < 1e-14);
    }

    #[test]
    fn rodrigues_rotates_x_into_y() {
        let v = rotate_about(
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            std::f64::consts::FRAC_PI_2,
        );
        assert!(distance(v, [0.0, 1.0, 0.0]) < 1e-15);
        let p = any_perpendicular(normalize([0.2, 0.9, -0.4]));
        assert!(dot(p, [0.2, 0.9, -0.4]).abs() < 1e-15 && (norm(p) - 1.0).abs() < 1e-15);
    }
}
