//! A synthetic survey built with the model, shared by the integration tests and the benchmark:
//! crossing strips flown in opposite directions at two heights over flat ground with bright
//! road markings and gable-roofed buildings of several slopes and aspects; a true mounting
//! (boresight + lever arm) is injected, the delivered points are georeferenced with the nominal
//! (zero) mounting, and range and attitude carry random noise.
#![allow(dead_code)]

use lidarqa_calib::{NedControlPoint, RawPoint, Strip, Tie, TieKind, TiePick};
use lidarqa_model::{Attitude, LinearObservation, Mounting, Ned, rotation_zyx, scanner_vector};
use nalgebra::{Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The injected mounting of the issue: boresight (0.05°, −0.03°, 0.08°), lever (0.10, −0.05, 0.20) m.
pub fn true_mounting() -> Mounting {
    Mounting {
        boresight_roll_rad: 0.05f64.to_radians(),
        boresight_pitch_rad: (-0.03f64).to_radians(),
        boresight_yaw_rad: 0.08f64.to_radians(),
        lever_arm_m: Vector3::new(0.10, -0.05, 0.20),
    }
}

#[derive(Debug, Clone, Copy)]
pub struct Building {
    pub centre: Vector2<f64>,
    /// Unit vector along the ridge (north, east).
    pub along: Vector2<f64>,
    pub half_length_m: f64,
    pub half_width_m: f64,
    pub eave_m: f64,
    pub ridge_m: f64,
}

impl Building {
    fn across(&self) -> Vector2<f64> {
        Vector2::new(-self.along.y, self.along.x)
    }
    fn local(&self, p: &Vector2<f64>) -> (f64, f64) {
        let d = p - self.centre;
        (d.dot(&self.along), d.dot(&self.across()))
    }
    pub fn inside(&self, p: &Vector2<f64>) -> bool {
        let (u, v) = self.local(p);
        u.abs() <= self.half_length_m && v.abs() <= self.half_width_m
    }
    /// Roof height (up, m) over a point inside the footprint.
    pub fn roof_up(&self, p: &Vector2<f64>) -> f64 {
        let (_, v) = self.local(p);
        self.ridge_m - (self.ridge_m - self.eave_m) * v.abs() / self.half_width_m
    }
    pub fn slope_deg(&self) -> f64 {
        ((self.ridge_m - self.eave_m) / self.half_width_m)
            .atan()
            .to_degrees()
    }
}

#[derive(Debug, Clone)]
pub struct Scene {
    pub half_size_m: f64,
    pub buildings: Vec<Building>,
    /// Bright square markings on the ground: centre and half side, m.
    pub markings: Vec<(Vector2<f64>, f64)>,
}

impl Scene {
    /// The default scene: ±`half` m, 12 gable roofs (slopes 15–45°, ridges every 30°), markings on
    /// a grid between them.
    pub fn new(half: f64) -> Scene {
        let mut buildings = Vec::new();
        let slopes = [15.0f64, 25.0, 35.0, 45.0];
        let mut k = 0;
        for i in 0..4 {
            for j in 0..3 {
                let c = Vector2::new(
                    -0.75 * half + 0.5 * half * i as f64,
                    -0.6 * half + 0.6 * half * j as f64,
                );
                let a = (30.0 * k as f64).to_radians();
                let hw = 6.0;
                let s = slopes[k % 4].to_radians();
                buildings.push(Building {
                    centre: c,
                    along: Vector2::new(a.cos(), a.sin()),
                    half_length_m: 8.0,
                    half_width_m: hw,
                    eave_m: 5.0,
                    ridge_m: 5.0 + hw * s.tan(),
                });
                k += 1;
            }
        }
        let mut markings = Vec::new();
        let n = 8;
        for i in 0..n {
            for j in 0..n {
                let c = Vector2::new(
                    -half + (i as f64 + 0.5) * 2.0 * half / n as f64,
                    -half + (j as f64 + 0.5) * 2.0 * half / n as f64,
                );
                if buildings
                    .iter()
                    .all(|b| (b.centre - c).norm() > b.half_length_m + 6.0)
                {
                    markings.push((c, 1.0));
                }
            }
        }
        Scene {
            half_size_m: half,
            buildings,
            markings,
        }
    }

    /// Surface height (up, m) at a horizontal position.
    pub fn up_at(&self, p: &Vector2<f64>) -> f64 {
        self.buildings
            .iter()
            .filter(|b| b.inside(p))
            .map(|b| b.roof_up(p))
            .fold(0.0, f64::max)
    }

    pub fn intensity_at(&self, p: &Vector2<f64>) -> u16 {
        if self.buildings.iter().any(|b| b.inside(p)) {
            80
        } else if self
            .markings
            .iter()
            .any(|(c, h)| (p.x - c.x).abs() <= *h && (p.y - c.y).abs() <= *h)
        {
            220
        } else {
            30
        }
    }

    /// First intersection (NED) of a ray with the scene; `None` for a wall hit.
    pub fn intersect(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<Vector3<f64>> {
        let t_ground = -o.z / d.z;
        let mut best = t_ground;
        for b in &self.buildings {
            let k = (b.ridge_m - b.eave_m) / b.half_width_m;
            for side in [1.0, -1.0] {
                let w = b.across() * side;
                let oxy = Vector2::new(o.x, o.y);
                let dxy = Vector2::new(d.x, d.y);
                // up = ridge − k (p − c)·w, up = −z.
                let den = -d.z + k * dxy.dot(&w);
                if den.abs() < 1e-12 {
                    continue;
                }
                let t = (b.ridge_m + o.z - k * (oxy - b.centre).dot(&w)) / den;
                if t <= 0.0 || t >= best {
                    continue;
                }
                let p = oxy + dxy * t;
                let (u, v) = b.local(&p);
                if u.abs() <= b.half_length_m && v * side >= 0.0 && v.abs() <= b.half_width_m {
                    best = t;
                }
            }
        }
        // Walls: the ray inside a footprint below its roof before `best` is a wall hit.
        let max_up = self.buildings.iter().map(|b| b.ridge_m).fold(0.0, f64::max);
        let t_top = (-max_up - o.z) / d.z;
        for s in 0..12 {
            let t = t_top + (best - t_top) * s as f64 / 12.0;
            if t >= best - 1e-6 {
                break;
            }
            let p = o + d * t;
            let xy = Vector2::new(p.x, p.y);
            if self
                .buildings
                .iter()
                .any(|b| b.inside(&xy) && -p.z < b.roof_up(&xy) - 1e-6)
            {
                return None;
            }
        }
        let p = o + d * best;
        let xy = Vector2::new(p.x, p.y);
        if (best - t_ground).abs() < 1e-9 && self.buildings.iter().any(|b| b.inside(&xy)) {
            return None;
        }
        Some(p)
    }
}

#[derive(Debug, Clone, Copy)]
pub struct Line {
    pub id: u32,
    pub heading_deg: f64,
    pub height_m: f64,
    /// Signed across-track offset of the line from the scene centre (to the right of the flight
    /// direction), m.
    pub offset_m: f64,
}

/// The default 8 lines: N, S, E, W at `h1`, then at `h2`; the two of each pair offset in
/// opposite directions.
pub fn lines(h1: f64, h2: f64) -> Vec<Line> {
    let mut out = Vec::new();
    let mut id = 1;
    for h in [h1, h2] {
        for heading in [0.0, 180.0, 90.0, 270.0] {
            out.push(Line {
                id,
                heading_deg: heading,
                height_m: h,
                offset_m: 20.0,
            });
            id += 1;
        }
    }
    out
}

#[derive(Debug, Clone)]
pub struct Noise {
    pub range_m: f64,
    pub attitude_rad: f64,
}

impl Default for Noise {
    fn default() -> Self {
        Noise {
            range_m: 0.02,
            attitude_rad: 0.001f64.to_radians(),
        }
    }
}

pub struct Survey {
    pub scene: Scene,
    pub truth: Mounting,
    pub strips: Vec<Strip>,
    /// Per strip, per point: the true surface point (NED).
    pub true_positions: Vec<Vec<Vector3<f64>>>,
    /// Per strip, per point: the noise-free delivered point (nominal mounting).
    pub clean_positions: Vec<Vec<Vector3<f64>>>,
}

/// Simulates `lines` over `scene` with spacing `spacing_m` (across and along track).
pub fn simulate(
    scene: &Scene,
    lines: &[Line],
    truth: &Mounting,
    noise: &Noise,
    spacing_m: f64,
    seed: u64,
) -> Survey {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n01 = Normal::new(0.0, 1.0).unwrap();
    let r_m_true = rotation_zyx(
        truth.boresight_roll_rad,
        truth.boresight_pitch_rad,
        truth.boresight_yaw_rad,
    );
    let half = scene.half_size_m;
    let fov = 25f64.to_radians();
    let speed = 60.0;
    let mut strips = Vec::new();
    let mut truths = Vec::new();
    let mut cleans = Vec::new();
    for line in lines {
        let hd = line.heading_deg.to_radians();
        let fwd = Vector2::new(hd.cos(), hd.sin());
        let right = Vector2::new(-hd.sin(), hd.cos());
        let start = -fwd * (half + 0.5 * line.height_m) + right * line.offset_m;
        let length = 2.0 * half + line.height_m;
        let n_lines = (length / spacing_m) as usize;
        let dtheta = spacing_m / line.height_m;
        let n_angles = (2.0 * fov / dtheta) as usize;
        let mut points = Vec::new();
        let mut tp = Vec::new();
        let mut cp = Vec::new();
        for i in 0..n_lines {
            let s = i as f64 * spacing_m + rng.random_range(0.0..0.3) * spacing_m;
            let time_s = 100_000.0 + line.id as f64 * 1000.0 + s / speed;
            let xy = start + fwd * s;
            // A gentle roll and pitch oscillation, as a real platform.
            let att = Attitude {
                roll_rad: (1.0f64).to_radians() * (s / 150.0).sin(),
                pitch_rad: (1.5f64).to_radians() + 0.3f64.to_radians() * (s / 90.0).cos(),
                heading_rad: hd + 0.5f64.to_radians() * (s / 200.0).sin(),
            };
            let origin = Vector3::new(xy.x, xy.y, -line.height_m);
            let r_n = rotation_zyx(att.roll_rad, att.pitch_rad, att.heading_rad);
            let theta0 = rng.random_range(0.0..1.0) * dtheta;
            for a in 0..n_angles {
                let theta = -fov + theta0 + a as f64 * dtheta;
                let dir = r_n * r_m_true * scanner_vector(1.0, theta);
                let beam_origin = origin + r_n * truth.lever_arm_m;
                // Cheap reject: the ground hit far outside the scene.
                let tg = -beam_origin.z / dir.z;
                let g = beam_origin + dir * tg;
                if g.x.abs() > half + 2.0 || g.y.abs() > half + 2.0 {
                    continue;
                }
                let Some(p) = scene.intersect(&beam_origin, &dir) else {
                    continue;
                };
                if p.x.abs() > half || p.y.abs() > half {
                    continue;
                }
                let range = (p - beam_origin).norm();
                let clean = origin + r_n * scanner_vector(range, theta);
                let att_noisy = Attitude {
                    roll_rad: att.roll_rad + noise.attitude_rad * n01.sample(&mut rng),
                    pitch_rad: att.pitch_rad + noise.attitude_rad * n01.sample(&mut rng),
                    heading_rad: att.heading_rad + noise.attitude_rad * n01.sample(&mut rng),
                };
                let obs = LinearObservation {
                    range_m: range + noise.range_m * n01.sample(&mut rng),
                    scan_angle_rad: theta,
                };
                let r_noisy = rotation_zyx(
                    att_noisy.roll_rad,
                    att_noisy.pitch_rad,
                    att_noisy.heading_rad,
                );
                let delivered = origin + r_noisy * scanner_vector(obs.range_m, theta);
                points.push(RawPoint {
                    position_m: Ned::from_vector(delivered),
                    origin_m: Ned::from_vector(origin),
                    attitude: att_noisy,
                    observation: obs,
                    out_of_plane_m: 0.0,
                    time_s,
                    intensity: scene.intensity_at(&Vector2::new(p.x, p.y)),
                });
                tp.push(p);
                cp.push(clean);
            }
        }
        strips.push(Strip {
            id: line.id.to_string(),
            points,
        });
        truths.push(tp);
        cleans.push(cp);
    }
    Survey {
        scene: scene.clone(),
        truth: *truth,
        strips,
        true_positions: truths,
        clean_positions: cleans,
    }
}

impl Survey {
    /// Where a feature at true position `t` (NED) appears in strip `s`: `t` plus the noise-free
    /// displacement of the nearest pulse (the mounting error's effect there), plus pick noise.
    pub fn pick(
        &self,
        s: usize,
        t: &Vector3<f64>,
        rng: &mut ChaCha8Rng,
        sigma_m: f64,
    ) -> Option<TiePick> {
        let tp = &self.true_positions[s];
        let (k, d) = tp
            .iter()
            .enumerate()
            .map(|(k, p)| (k, (p.x - t.x).powi(2) + (p.y - t.y).powi(2)))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        if d > 1.0 {
            return None;
        }
        let disp = self.clean_positions[s][k] - tp[k];
        let n01 = Normal::new(0.0, 1.0).unwrap();
        Some(TiePick {
            strip: self.strips[s].id.clone(),
            north_m: t.x + disp.x + sigma_m * n01.sample(rng),
            east_m: t.y + disp.y + sigma_m * n01.sample(rng),
        })
    }

    /// Hand-picked ties: marking corners (flat ground) and points on roof faces, picked in every
    /// strip that covers them (features at least 2.5 m inside the scene).
    pub fn hand_ties(&self, pick_sigma_m: f64, seed: u64) -> Vec<Tie> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut features: Vec<Vector3<f64>> = Vec::new();
        for (c, h) in &self.scene.markings {
            features.push(Vector3::new(c.x + h, c.y - h, 0.0));
        }
        for b in &self.scene.buildings {
            for side in [1.0, -1.0] {
                let xy = b.centre + b.across() * side * 0.5 * b.half_width_m + b.along * 2.0;
                features.push(Vector3::new(xy.x, xy.y, -b.roof_up(&xy)));
            }
        }
        let lim = self.scene.half_size_m - 2.5;
        let mut ties = Vec::new();
        for (k, f) in features.iter().enumerate() {
            if f.x.abs() > lim || f.y.abs() > lim {
                continue;
            }
            let picks: Vec<TiePick> = (0..self.strips.len())
                .filter_map(|s| self.pick(s, f, &mut rng, pick_sigma_m))
                .collect();
            if picks.len() >= 2 {
                ties.push(Tie {
                    id: format!("t{k}"),
                    picks,
                    kind: TieKind::Feature,
                });
            }
        }
        ties
    }

    /// Ground control: the first `n` ties on flat ground as surveyed targets (true position).
    pub fn control_for(&self, ties: &[Tie], n: usize) -> Vec<NedControlPoint> {
        ties.iter()
            .filter_map(|t| {
                let k: usize = t.id[1..].parse().ok()?;
                let (c, h) = self.scene.markings.get(k)?;
                Some(NedControlPoint {
                    id: t.id.clone(),
                    position_m: Ned::new(c.x + h, c.y - h, 0.0),
                    target_radius_m: None,
                    sigma_vertical_m: None,
                })
            })
            .step_by(3)
            .take(n)
            .collect()
    }
}
