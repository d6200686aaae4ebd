//! Unit quaternions for orientations: scalar first, `q = [w, x, y, z]` (the layout of
//! pytransform3d and movement_primitives), representing the rotation by angle `theta` about the
//! unit axis `n` as `[cos(theta/2), sin(theta/2) n]`.
//!
//! The logarithm and exponential are those of Ude, Nemec, Petrič, Morimoto (ICRA 2014):
//!
//! ```text
//! log(q) = arccos(w) v / |v|              (0 if v = 0)       half the rotation vector
//! exp(r) = [cos |r|, sin |r| r / |r|]     ([1, 0, 0, 0] if r = 0)
//! ```
//!
//! `log` is taken as written, not on the shorter of `q` and `-q`: `2 |log(q)|` lies in
//! `[0, 2 pi]`, so `exp(log(q)) = q` for every unit `q`, sign included. An orientation DMP
//! integrates a sign-continuous quaternion and measures the distance to its goal with this `log`,
//! which keeps it continuous along any demonstrated rotation of less than a full turn.

/// `[w, x, y, z]`.
pub type Quaternion = [f64; 4];

/// The identity rotation.
pub const IDENTITY: Quaternion = [1.0, 0.0, 0.0, 0.0];

/// Hamilton product `a * b` (rotation `b` first, then `a`).
#[inline]
pub fn product(a: &Quaternion, b: &Quaternion) -> Quaternion {
    let [aw, ax, ay, az] = *a;
    let [bw, bx, by, bz] = *b;
    [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]
}

/// `conj(q) = [w, -v]`, the inverse of a unit quaternion.
#[inline]
pub fn conjugate(q: &Quaternion) -> Quaternion {
    [q[0], -q[1], -q[2], -q[3]]
}

#[inline]
pub fn dot(a: &Quaternion, b: &Quaternion) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

#[inline]
pub fn norm(q: &Quaternion) -> f64 {
    dot(q, q).sqrt()
}

/// `log(q) = arccos(w) v / |v|`, half the rotation vector (module docs). Computed as
/// `atan2(|v|, w) v / |v|`, which equals it for unit `q` and stays accurate near `w = +-1`,
/// where `arccos` loses half its digits.
#[inline]
pub fn log(q: &Quaternion) -> [f64; 3] {
    let s = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if s == 0.0 {
        return [0.0; 3];
    }
    let k = s.atan2(q[0]) / s;
    [k * q[1], k * q[2], k * q[3]]
}

/// Whether `log` jumped between two samples of a continuous path of rotations: where the path
/// passes a full turn from where its logarithms are taken, `log` goes to the other way round,
/// its half-angle vector from about `pi n` to `-pi n`, while a continuous path moves it far less
/// than `pi` per sample.
#[inline]
pub fn log_wrapped(before: &[f64; 3], after: &[f64; 3]) -> bool {
    let d = [0, 1, 2].map(|i| after[i] - before[i]);
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > std::f64::consts::PI * std::f64::consts::PI
}

/// `exp(r) = [cos |r|, sin |r| r / |r|]`, a unit quaternion for every finite `r`.
///
/// Below `|r| = 0.03` (an integration step of an orientation DMP is far below that) the Taylor
/// series of `cos` and `sin(s)/s` to the `s^8` term is used instead of `sin_cos`: its truncation
/// error is below `0.03^10 / 10! < 2e-22`, far under the rounding unit, and it avoids two libm
/// calls in the rollout's inner loop.
#[inline]
pub fn exp(r: &[f64; 3]) -> Quaternion {
    let s2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    let (c, k) = if s2 < 9e-4 {
        // cos s = sum (-1)^j s^2j / (2j)!, sin(s)/s = sum (-1)^j s^2j / (2j+1)!, j <= 4.
        let c = 1.0 - s2 / 2.0 * (1.0 - s2 / 12.0 * (1.0 - s2 / 30.0 * (1.0 - s2 / 56.0)));
        let k = 1.0 - s2 / 6.0 * (1.0 - s2 / 20.0 * (1.0 - s2 / 42.0 * (1.0 - s2 / 72.0)));
        (c, k)
    } else {
        let s = s2.sqrt();
        let (sin, cos) = s.sin_cos();
        (cos, sin / s)
    };
    [c, k * r[0], k * r[1], k * r[2]]
}

/// `q` or `-q`, whichever is on the side of `reference` (`dot >= 0`): the same rotation.
#[inline]
pub fn same_hemisphere(q: &Quaternion, reference: &Quaternion) -> Quaternion {
    if dot(q, reference) < 0.0 {
        [-q[0], -q[1], -q[2], -q[3]]
    } else {
        *q
    }
}

/// Scales `q` back onto the unit sphere after a product of unit quaternions has drifted off it
/// by rounding (`|q|^2 = 1 + e` with `e` ~ 1e-16): one Newton step for `1/sqrt`, exact to
/// `O(e^2)`, in place of a square root and a division.
#[inline]
pub fn renormalize(q: &Quaternion) -> Quaternion {
    let k = 1.5 - 0.5 * dot(q, q);
    [k * q[0], k * q[1], k * q[2], k * q[3]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn axis_angle(axis: [f64; 3], angle: f64) -> Quaternion {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let s = (angle / 2.0).sin() / n;
        [(angle / 2.0).cos(), s * axis[0], s * axis[1], s * axis[2]]
    }

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    /// Rotates a vector by the matrix of q (the textbook formula, independent of `product`).
    fn rotate(q: &Quaternion, v: [f64; 3]) -> [f64; 3] {
        let [w, x, y, z] = *q;
        let m = [
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
        ];
        [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
    }

    proptest! {
        /// The product composes rotations: R(a * b) v = R(a) R(b) v.
        #[test]
        fn product_composes_rotations(
            a in prop::array::uniform3(-1.0f64..1.0), ta in -6.0f64..6.0,
            b in prop::array::uniform3(-1.0f64..1.0), tb in -6.0f64..6.0,
            v in prop::array::uniform3(-2.0f64..2.0),
        ) {
            prop_assume!(a.iter().map(|x| x * x).sum::<f64>() > 1e-3);
            prop_assume!(b.iter().map(|x| x * x).sum::<f64>() > 1e-3);
            let (qa, qb) = (axis_angle(a, ta), axis_angle(b, tb));
            let lhs = rotate(&product(&qa, &qb), v);
            let rhs = rotate(&qa, rotate(&qb, v));
            prop_assert!(close(&lhs, &rhs, 1e-12));
            let id = product(&qa, &conjugate(&qa));
            prop_assert!(close(&id, &IDENTITY, 1e-15));
        }

        /// exp inverts log for every unit quaternion, including w < 0 (rotations beyond pi), and
        /// 2 log is the rotation vector angle * axis for angles in (-2 pi, 2 pi).
        #[test]
        fn exp_inverts_log(axis in prop::array::uniform3(-1.0f64..1.0), angle in -6.2f64..6.2) {
            let n = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
            prop_assume!(n > 1e-3);
            let q = axis_angle(axis, angle);
            prop_assert!(close(&exp(&log(&q)), &q, 1e-14));
            let r = log(&q).map(|c| 2.0 * c);
            let want = axis.map(|c| angle * c / n);
            prop_assert!(close(&r, &want, 1e-12), "{:?} vs {:?}", r, want);
        }

        /// Both branches of exp agree with the closed form and give unit quaternions.
        #[test]
        fn exp_is_unit_and_matches_sin_cos(r in prop::array::uniform3(-0.05f64..0.05)) {
            let q = exp(&r);
            let s = r.iter().map(|x| x * x).sum::<f64>().sqrt();
            prop_assume!(s > 0.0);
            let want = [s.cos(), s.sin() * r[0] / s, s.sin() * r[1] / s, s.sin() * r[2] / s];
            prop_assert!(close(&q, &want, 2e-16));
            prop_assert!((norm(&q) - 1.0).abs() < 4e-16);
        }
    }

    #[test]
    fn log_and_exp_of_the_identity_are_exact() {
        assert_eq!(log(&IDENTITY), [0.0; 3]);
        assert_eq!(exp(&[0.0; 3]), IDENTITY);
        let q = axis_angle([0.3, -0.2, 0.9], 1.1);
        assert_eq!(log(&product(&q, &conjugate(&q))), [0.0; 3]);
    }

    #[test]
    fn same_hemisphere_and_renormalize() {
        let q = axis_angle([0.0, 0.0, 1.0], 0.4);
        let m = q.map(|c| -c);
        assert_eq!(same_hemisphere(&m, &q), q);
        assert_eq!(same_hemisphere(&q, &q), q);
        let drifted = q.map(|c| c * (1.0 + 1e-9));
        assert!((norm(&renormalize(&drifted)) - 1.0).abs() < 1e-16);
    }
}
