//! The 2DIY's five-bar pantograph: forward kinematics and the Jacobian as
//! the vendor's client computes them (`HaplyHAPI.py` 1.0.1, class
//! `Pantograph`, transcribed operation for operation, so both give the same
//! numbers to the last bits), and the inverse kinematics the emulator needs.
//!
//! Frame: motor 1's axis at the origin, motor 2's at `x = d`, `y` away
//! from the motors, metres. Angles in degrees, as the board reports them;
//! the Jacobian per radian.

use core::f64::consts::PI;

/// Link lengths, m.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Links {
    /// Proximal links (both motors), m. Vendor: 0.07.
    pub l: f64,
    /// Distal links, m. Vendor: 0.09.
    pub big_l: f64,
    /// Distance between the motor axes, m. Vendor: 0.038 (hardware v3),
    /// 0 (v2).
    pub d: f64,
}

impl Links {
    /// The vendor's values for hardware `version` (3: the plastic 2DIY,
    /// otherwise the metal v2), `Pantograph.__init__`.
    #[must_use]
    pub fn vendor(version: u8) -> Self {
        Links {
            l: 0.07,
            big_l: 0.09,
            d: if version == 3 { 0.038 } else { 0.0 },
        }
    }
}

/// The end effector at a pair of motor angles, and the Jacobian there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// End effector position, m.
    pub x_m: f64,
    /// End effector position, m.
    pub y_m: f64,
    /// `∂x/∂θ1`, `∂y/∂θ1`, `∂x/∂θ2`, `∂y/∂θ2`, m/rad (the vendor's J11,
    /// J12, J21, J22: the transpose of the usual Jacobian).
    pub j: [f64; 4],
}

impl Pose {
    /// Motor torques (N m) that push the end effector with `(fx, fy)` N:
    /// `τ = Jᵀ f` (`Pantograph.torqueCalculation`).
    #[must_use]
    pub fn torques(&self, fx: f64, fy: f64) -> [f64; 2] {
        let [j11, j12, j21, j22] = self.j;
        [j11 * fx + j12 * fy, j21 * fx + j22 * fy]
    }

    /// The end-effector force `(fx, fy)` N that motor torques `tau` make
    /// (`τ = Jᵀ f` solved for `f`); zero at a singular pose.
    #[must_use]
    pub fn force(&self, tau: [f64; 2]) -> [f64; 2] {
        let [j11, j12, j21, j22] = self.j;
        let det = j11 * j22 - j12 * j21;
        if det.abs() < 1e-12 {
            return [0.0, 0.0];
        }
        [
            (j22 * tau[0] - j12 * tau[1]) / det,
            (-j21 * tau[0] + j11 * tau[1]) / det,
        ]
    }
}

/// Forward kinematics and Jacobian at `angles` (degrees), as
/// `Pantograph.forwardKinematics` computes them.
#[must_use]
pub fn forward(links: &Links, angles_deg: [f64; 2]) -> Pose {
    let (l1, l2, big_l1, big_l2, d) = (links.l, links.l, links.big_l, links.big_l, links.d);
    let th1 = PI / 180.0 * angles_deg[0];
    let th2 = PI / 180.0 * angles_deg[1];
    let (c1, c2, s1, s2) = (th1.cos(), th2.cos(), th1.sin(), th2.sin());
    let x_a = l1 * c1;
    let y_a = l1 * s1;
    let x_b = d + l2 * c2;
    let y_b = l2 * s2;
    let hx = x_b - x_a;
    let hy = y_b - y_a;
    let hh = hx.powi(2) + hy.powi(2);
    let hm = hh.sqrt();
    let (c_b, h1x, h1y) = if hm == 0.0 {
        (0.0, 0.0, 0.0)
    } else {
        let c_b = -(big_l2.powi(2) - big_l1.powi(2) - hh) / (2.0 * big_l1 * hm);
        (c_b, big_l1 * c_b * hx / hm, big_l1 * c_b * hy / hm)
    };
    let h1h1 = h1x.powi(2) + h1y.powi(2);
    let h1m = h1h1.sqrt();
    let s_b = (1.0 - c_b.powi(2)).sqrt();
    let (lx, ly) = if h1m == 0.0 {
        (0.0, 0.0)
    } else {
        (-big_l1 * s_b * h1y / h1m, big_l1 * s_b * h1x / h1m)
    };
    let x_p = x_a + h1x + lx;
    let y_p = y_a + h1y + ly;
    let phi1 = ((x_p - l1 * c1) / big_l1).acos();
    let phi2 = ((x_p - d - l2 * c2) / big_l2).acos();
    let (c11, s11, c22, s22) = (phi1.cos(), phi1.sin(), phi2.cos(), phi2.sin());
    let dn = big_l1 * (c11 * s22 - c22 * s11);
    let (eta, nu) = if dn == 0.0 {
        (0.0, 0.0)
    } else {
        (
            (-big_l1 * c11 * s22 + big_l1 * c22 * s11 - c1 * l1 * s22 + c22 * l1 * s1) / dn,
            l2 * (c2 * s22 - c22 * s2) / dn,
        )
    };
    Pose {
        x_m: x_p,
        y_m: y_p,
        j: [
            -big_l1 * eta * s11 - big_l1 * s11 - l1 * s1,
            big_l1 * c11 * eta + big_l1 * c11 + c1 * l1,
            -big_l1 * s11 * nu,
            big_l1 * c11 * nu,
        ],
    }
}

/// The motor angles (degrees) that put the end effector at `(x, y)`, elbows
/// out (motor 1's link to the left, motor 2's to the right, as at the
/// vendor's calibration pose); None out of reach.
#[must_use]
pub fn inverse(links: &Links, x_m: f64, y_m: f64) -> Option<[f64; 2]> {
    let side = |ox: f64, sign: f64| {
        let (dx, dy) = (x_m - ox, y_m);
        let r = dx.hypot(dy);
        let cos = (links.l.powi(2) + r.powi(2) - links.big_l.powi(2)) / (2.0 * links.l * r);
        (r > 0.0 && cos.abs() <= 1.0).then(|| (dy.atan2(dx) + sign * cos.acos()).to_degrees())
    };
    Some([side(0.0, 1.0)?, side(links.d, -1.0)?])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vendor's v3 calibration pose, (168°, 12°), is the end effector at
    /// (0.019, 0.03574) m (the research note's value from the vendor's
    /// client), and the Jacobian there matches finite differences.
    #[test]
    fn the_calibration_pose_and_its_jacobian_are_the_vendors() {
        let links = Links::vendor(3);
        let p = forward(&links, [168.0, 12.0]);
        assert!((p.x_m - 0.019).abs() < 1e-12, "{p:?}");
        assert!((p.y_m - 0.035_74).abs() < 1e-5, "{p:?}");
        let h: f64 = 1e-6;
        for k in 0..2 {
            let mut a = [168.0, 12.0];
            a[k] += h.to_degrees();
            let q = forward(&links, a);
            let (dx, dy) = ((q.x_m - p.x_m) / h, (q.y_m - p.y_m) / h);
            assert!((dx - p.j[2 * k]).abs() < 1e-5, "{k}: {dx} vs {:?}", p.j);
            assert!((dy - p.j[2 * k + 1]).abs() < 1e-5, "{k}: {dy} vs {:?}", p.j);
        }
    }

    #[test]
    fn inverse_kinematics_undoes_forward_over_the_workspace() {
        let links = Links::vendor(3);
        for i in 0..=20 {
            for k in 0..=10 {
                let (x, y) = (-0.03 + 0.005 * f64::from(i), 0.05 + 0.008 * f64::from(k));
                let a = inverse(&links, x, y).unwrap();
                let p = forward(&links, a);
                assert!(
                    (p.x_m - x).abs() < 1e-12 && (p.y_m - y).abs() < 1e-12,
                    "{x} {y}"
                );
            }
        }
        assert_eq!(inverse(&links, 0.0, 0.3), None, "out of reach");
    }

    #[test]
    fn force_undoes_torques() {
        let p = forward(&Links::vendor(3), [130.0, 50.0]);
        let f = p.force(p.torques(0.7, -1.3));
        assert!((f[0] - 0.7).abs() < 1e-12 && (f[1] + 1.3).abs() < 1e-12);
    }
}
