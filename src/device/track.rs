//! Friction on a device with more than one axis. The friction models are
//! one-dimensional, along a surface; on a 2- or 3-axis device the loop
//! renders the model along a straight [`Track`] and holds the hand on it
//! with a stiff, damped virtual wall on the other axes. Pure: positions in,
//! forces out.

use super::backend::{MAX_AXES, Vector};

/// A straight track through a device's workspace, and the wall that holds
/// the hand on it. Device frame, SI units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Track {
    /// The track's point at position 0, m.
    pub origin_m: Vector,
    /// Its direction (normalised when used): position grows this way.
    pub direction: Vector,
    /// Stiffness of the wall across the track, N/m.
    pub wall_stiffness_n_m: f64,
    /// Damping of the wall across the track, N s/m.
    pub wall_damping_n_s_m: f64,
}

impl Track {
    /// A one-axis device's track: its axis, no wall (nothing to hold).
    #[must_use]
    pub fn axis() -> Self {
        Track {
            origin_m: [0.0; MAX_AXES],
            direction: [1.0, 0.0, 0.0],
            wall_stiffness_n_m: 0.0,
            wall_damping_n_s_m: 0.0,
        }
    }

    /// Why this track cannot be rendered, if it cannot: a direction of no
    /// length, a value not finite, a negative wall.
    #[must_use]
    pub fn problem(&self) -> Option<String> {
        let finite = self
            .origin_m
            .iter()
            .chain(&self.direction)
            .chain([&self.wall_stiffness_n_m, &self.wall_damping_n_s_m])
            .all(|v| v.is_finite());
        if !finite {
            return Some("track values must be finite numbers".into());
        }
        if norm(self.direction) < 1e-9 {
            return Some("track direction must not be zero".into());
        }
        if self.wall_stiffness_n_m < 0.0 || self.wall_damping_n_s_m < 0.0 {
            return Some("wall stiffness and damping must be at least 0".into());
        }
        None
    }

    fn unit(&self) -> Vector {
        let n = norm(self.direction);
        if n > 0.0 {
            self.direction.map(|d| d / n)
        } else {
            [1.0, 0.0, 0.0]
        }
    }

    /// Where `p` is: its position along the track, m, and its offset
    /// across (the vector from the track to `p`).
    #[must_use]
    pub fn split(&self, p: Vector) -> (f64, Vector) {
        let u = self.unit();
        let d = sub(p, self.origin_m);
        let along = dot(d, u);
        (along, sub(d, u.map(|c| c * along)))
    }

    /// The force vector for `along_n` along the track plus the wall's push
    /// back towards it, for a hand `offset` m off the track moving off it
    /// at `offset_velocity` m/s, its magnitude at most `limit_n`. The wall
    /// comes first (it keeps the hand where the one-dimensional model
    /// holds): the force along the track gets what the wall leaves of the
    /// limit, and a wall beyond the limit alone is scaled down to it.
    #[must_use]
    pub fn force(
        &self,
        along_n: f64,
        offset: Vector,
        offset_velocity: Vector,
        limit_n: f64,
    ) -> Vector {
        let u = self.unit();
        let mut wall = [0.0; MAX_AXES];
        for i in 0..MAX_AXES {
            wall[i] =
                -self.wall_stiffness_n_m * offset[i] - self.wall_damping_n_s_m * offset_velocity[i];
        }
        // Only the wall's part across the track counts as wall.
        let w_along = dot(wall, u);
        let mut wall = sub(wall, u.map(|c| c * w_along));
        let w = norm(wall);
        if w > limit_n {
            let k = limit_n / w;
            wall = wall.map(|c| c * k);
        }
        let room = (limit_n * limit_n - norm(wall).powi(2)).max(0.0).sqrt();
        let along = along_n.clamp(-room, room);
        [0, 1, 2].map(|i| wall[i] + u[i] * along)
    }
}

fn dot(a: Vector, b: Vector) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn sub(a: Vector, b: Vector) -> Vector {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The length of `v`.
#[must_use]
pub fn norm(v: Vector) -> f64 {
    dot(v, v).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track() -> Track {
        Track {
            origin_m: [0.02, 0.1, 0.0],
            direction: [2.0, 0.0, 0.0],
            wall_stiffness_n_m: 1000.0,
            wall_damping_n_s_m: 5.0,
        }
    }

    #[test]
    fn a_point_splits_into_its_place_along_and_its_offset_across() {
        let (along, off) = track().split([0.03, 0.102, 0.0]);
        assert!((along - 0.01).abs() < 1e-15);
        assert!((off[1] - 0.002).abs() < 1e-15 && off[0].abs() < 1e-15);
    }

    #[test]
    fn the_wall_pushes_back_to_the_track_and_friction_acts_along_it() {
        let f = track().force(-1.5, [0.0, 0.002, 0.0], [0.0, 0.1, 0.0], 100.0);
        assert_eq!(f[0], -1.5);
        assert!((f[1] - (-2.0 - 0.5)).abs() < 1e-12, "{f:?}");
    }

    #[test]
    fn the_force_never_exceeds_the_limit_and_the_wall_comes_first() {
        // Wall 1.2 N across, friction 3 N along, limit 2 N: the wall whole,
        // the friction what is left, 1.6 N.
        let f = track().force(3.0, [0.0, 0.0012, 0.0], [0.0; 3], 2.0);
        assert!((norm(f) - 2.0).abs() < 1e-12, "{f:?}");
        assert!(
            (f[1] + 1.2).abs() < 1e-12 && (f[0] - 1.6).abs() < 1e-12,
            "{f:?}"
        );
        // A wall beyond the limit alone: scaled to it, nothing along.
        let f = track().force(-3.0, [0.0, 0.01, 0.0], [0.0; 3], 2.0);
        assert_eq!(f, [0.0, -2.0, 0.0]);
    }

    #[test]
    fn a_track_without_direction_or_with_a_negative_wall_is_refused() {
        let mut t = track();
        t.direction = [0.0; 3];
        assert!(t.problem().unwrap().contains("direction"));
        let mut t = track();
        t.wall_damping_n_s_m = -1.0;
        assert!(t.problem().unwrap().contains("at least 0"));
        assert_eq!(track().problem(), None);
    }
}
