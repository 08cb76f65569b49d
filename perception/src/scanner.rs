//! A simulated spinning LiDAR: beams fanned over an elevation range, swept through a full
//! turn, ray-cast against terrain boxes, with Gaussian range noise, dropouts and
//! occlusion by the robot's own body.

use nalgebra::{Rotation3, Vector3};
use rand::Rng;

use cbfgen::error::{finite, within, CbfError};
use cbfgen::geometry::OrientedBox;

/// What the scanner models. One scan is `beams × azimuth_steps` rays from one pose (a
/// 10 Hz sweep is short beside the body's motion at the gait's speeds, so the pose is
/// held through the sweep).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lidar {
    /// Beams, evenly spread over `[min_elevation, max_elevation]`.
    pub beams: usize,
    /// Lowest beam's elevation \[rad\] (negative: below the horizon).
    pub min_elevation: f64,
    /// Highest beam's elevation \[rad\].
    pub max_elevation: f64,
    /// Azimuth steps per full turn.
    pub azimuth_steps: usize,
    /// Returns beyond this range are lost \[m\].
    pub max_range: f64,
    /// Standard deviation of the range noise \[m\].
    pub range_noise: f64,
    /// Probability that a return is dropped.
    pub dropout: f64,
}

impl Default for Lidar {
    /// A 32-beam sensor tilted down for terrain, −55° to +5°, 0.5° azimuth steps, 20 m,
    /// 1 cm range noise, 5 % dropouts.
    fn default() -> Self {
        Self {
            beams: 32,
            min_elevation: (-55f64).to_radians(),
            max_elevation: 5f64.to_radians(),
            azimuth_steps: 720,
            max_range: 20.0,
            range_noise: 0.01,
            dropout: 0.05,
        }
    }
}

/// Most rays one scan may cast (a bound on the points it returns).
pub const MAX_RAYS: usize = 10_000_000;

impl Lidar {
    /// `Ok` when the settings describe a sensor.
    ///
    /// # Errors
    /// Zero beams or steps, more than [`MAX_RAYS`] rays, elevations outside ±90° or out
    /// of order, a range, noise or dropout outside its domain.
    pub fn validate(&self) -> Result<(), CbfError> {
        if self.beams == 0 || self.azimuth_steps == 0 {
            return Err(CbfError::NotPositive { what: "lidar beams and azimuth steps", value: 0.0 });
        }
        let rays = self.beams.saturating_mul(self.azimuth_steps);
        if rays > MAX_RAYS {
            return Err(CbfError::TooLarge { what: "lidar rays per scan", value: rays, max: MAX_RAYS });
        }
        let right = std::f64::consts::FRAC_PI_2;
        within("lidar min elevation [rad]", self.min_elevation, -right, right, "[-pi/2, pi/2]")?;
        within("lidar max elevation [rad]", self.max_elevation, self.min_elevation, right, "[min elevation, pi/2]")?;
        within("lidar max range [m]", self.max_range, 1e-3, 1e4, "[1e-3, 1e4]")?;
        within("lidar range noise [m]", self.range_noise, 0.0, 1.0, "[0, 1]")?;
        within("lidar dropout", self.dropout, 0.0, 1.0, "[0, 1]")?;
        Ok(())
    }

    /// One scan from `origin` with heading `yaw` \[rad\], the sensor level: the hit points
    /// in the world frame. Rays that first hit an `occluder` (the robot's own body) or
    /// nothing within range return no point.
    ///
    /// # Errors
    /// Invalid settings ([`Lidar::validate`]) or a non-finite pose.
    pub fn scan(
        &self,
        origin: &Vector3<f64>,
        yaw: f64,
        terrain: &[OrientedBox],
        occluders: &[OrientedBox],
        rng: &mut impl Rng,
    ) -> Result<Vec<Vector3<f64>>, CbfError> {
        finite("lidar yaw", yaw)?;
        self.scan_oriented(origin, &Rotation3::from_axis_angle(&Vector3::z_axis(), yaw), terrain, occluders, rng)
    }

    /// [`Lidar::scan`] with the sensor turned by `orientation` (sensor to world: the
    /// sensor's x is its zero azimuth, its z the axis it spins about), as on a pitching
    /// body.
    ///
    /// # Errors
    /// Invalid settings ([`Lidar::validate`]) or a non-finite pose.
    pub fn scan_oriented(
        &self,
        origin: &Vector3<f64>,
        orientation: &Rotation3<f64>,
        terrain: &[OrientedBox],
        occluders: &[OrientedBox],
        rng: &mut impl Rng,
    ) -> Result<Vec<Vector3<f64>>, CbfError> {
        self.validate()?;
        for &c in origin.iter() {
            finite("lidar origin", c)?;
        }
        for &c in orientation.matrix().iter() {
            finite("lidar orientation", c)?;
        }
        let heading = orientation;
        let mut points = Vec::new();
        for b in 0..self.beams {
            let f = if self.beams == 1 { 0.5 } else { b as f64 / (self.beams - 1) as f64 };
            let elevation = self.min_elevation + f * (self.max_elevation - self.min_elevation);
            for a in 0..self.azimuth_steps {
                let azimuth = std::f64::consts::TAU * a as f64 / self.azimuth_steps as f64;
                let dir = heading
                    * Vector3::new(elevation.cos() * azimuth.cos(), elevation.cos() * azimuth.sin(), elevation.sin());
                let hit = first_hit(origin, &dir, terrain);
                let blocked = first_hit(origin, &dir, occluders);
                let Some(range) = hit.filter(|&t| t <= self.max_range && blocked.is_none_or(|o| o > t)) else {
                    continue;
                };
                if rng.random::<f64>() < self.dropout {
                    continue;
                }
                let noisy = (range + self.range_noise * standard_normal(rng)).max(0.0);
                points.push(origin + dir * noisy);
            }
        }
        Ok(points)
    }
}

/// Distance along the unit ray to the nearest box it enters (or starts in: 0).
fn first_hit(origin: &Vector3<f64>, dir: &Vector3<f64>, boxes: &[OrientedBox]) -> Option<f64> {
    boxes.iter().filter_map(|b| ray_box(origin, dir, b)).min_by(f64::total_cmp)
}

/// Slab test in the box's frame.
fn ray_box(origin: &Vector3<f64>, dir: &Vector3<f64>, b: &OrientedBox) -> Option<f64> {
    let rt = b.rotation().inverse();
    let o = rt * (origin - b.center());
    let d = rt * dir;
    let (mut near, mut far) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        let h = b.half_extents()[k];
        if d[k].abs() < 1e-15 {
            if o[k].abs() > h {
                return None;
            }
            continue;
        }
        let (t1, t2) = ((-h - o[k]) / d[k], (h - o[k]) / d[k]);
        near = near.max(t1.min(t2));
        far = far.min(t1.max(t2));
        if near > far {
            return None;
        }
    }
    Some(near)
}

/// A standard normal draw (Box–Muller).
fn standard_normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn a_ray_straight_down_hits_the_top_face_at_its_height() {
        let floor = OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, -0.5), Vector3::new(5.0, 5.0, 0.5)).unwrap();
        let t = ray_box(&Vector3::new(0.3, 0.2, 1.0), &Vector3::new(0.0, 0.0, -1.0), &floor).unwrap();
        assert!((t - 1.0).abs() < 1e-12);
        assert!(ray_box(&Vector3::new(0.3, 0.2, 1.0), &Vector3::new(0.0, 0.0, 1.0), &floor).is_none());
    }

    #[test]
    fn a_noiseless_scan_lies_on_the_floor_and_an_occluder_hides_what_is_under_it() {
        let floor = OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, -0.5), Vector3::new(50.0, 50.0, 0.5)).unwrap();
        let lidar = Lidar { range_noise: 0.0, dropout: 0.0, ..Lidar::default() };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let origin = Vector3::new(0.0, 0.0, 0.6);
        let open = lidar.scan(&origin, 0.3, &[floor], &[], &mut rng).unwrap();
        assert!(!open.is_empty() && open.iter().all(|p| p.z.abs() < 1e-9));
        let body = OrientedBox::axis_aligned(Vector3::new(0.0, 0.0, 0.4), Vector3::new(0.5, 0.3, 0.1)).unwrap();
        let hidden = lidar.scan(&origin, 0.3, &[floor], &[body], &mut rng).unwrap();
        assert!(hidden.len() < open.len());
        // No return from under the body's footprint.
        assert!(hidden.iter().all(|p| p.x.abs() > 0.5 || p.y.abs() > 0.3));
    }
}
