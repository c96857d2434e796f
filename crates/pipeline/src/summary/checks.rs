//! Per-point checks tallied over a survey: how the incidence term was taken, the recovered
//! against the file's scan angle, and the recovery residual.

use lidarqa_model::Warning;
use lidarqa_products::IncidenceCounts;
use lidarqa_tpu::IncidenceClass;
use serde::{Deserialize, Serialize};

/// How the incidence term was taken, per point (the `incidence_class` written with each point,
/// [`lidarqa_tpu::IncidenceClass`]), or why it was left out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct IncidenceTally {
    /// Normals read from the file's `NormalX/NormalY/NormalZ` (PDAL `filters.normal`).
    pub file_normals: u64,
    /// File normals that were zero or not finite (term left out).
    pub invalid_file_normals: u64,
    /// Planar neighbourhoods whose plane the beam meets: a fitted normal.
    pub planar: u64,
    /// Of `planar`, those whose k nearest neighbours were linear (e.g. one scan line) and whose
    /// widened neighbourhood, reaching the next scan lines, is planar.
    #[serde(default)]
    pub planar_widened: u64,
    /// Linear neighbourhoods (e.g. one scan line), also when widened: the normal across the
    /// line nearest the vertical.
    pub linear: u64,
    /// Judged planes (or normals across a line) that contain the beam, as the returns of one
    /// scan plane do whatever they hit: the prior for an unmeasured surface.
    #[serde(default)]
    pub beam_in_plane: u64,
    /// Scattered neighbourhoods (vegetation, noise): the prior for an unmeasured surface.
    pub scattered: u64,
    /// Fewer neighbours than a plane needs: term left out.
    pub too_few_points: u64,
}

impl IncidenceTally {
    /// Counts one point of class `c` (nothing for [`IncidenceClass::NoTerm`]).
    pub fn add(&mut self, c: IncidenceClass) {
        match c {
            IncidenceClass::NoTerm => {}
            IncidenceClass::FileNormal => self.file_normals += 1,
            IncidenceClass::InvalidFileNormal => self.invalid_file_normals += 1,
            IncidenceClass::Planar => self.planar += 1,
            IncidenceClass::PlanarWidened => {
                self.planar += 1;
                self.planar_widened += 1;
            }
            IncidenceClass::AcrossLine => self.linear += 1,
            IncidenceClass::BeamInPlane => self.beam_in_plane += 1,
            IncidenceClass::Scattered => self.scattered += 1,
            IncidenceClass::TooFew => self.too_few_points += 1,
        }
    }

    /// Adds another tally.
    pub fn merge(&mut self, o: &IncidenceTally) {
        self.file_normals += o.file_normals;
        self.invalid_file_normals += o.invalid_file_normals;
        self.planar += o.planar;
        self.planar_widened += o.planar_widened;
        self.linear += o.linear;
        self.beam_in_plane += o.beam_in_plane;
        self.scattered += o.scattered;
        self.too_few_points += o.too_few_points;
    }

    /// The summary's `incidence` block.
    pub fn counts(&self) -> IncidenceCounts {
        IncidenceCounts {
            file_normals: self.file_normals,
            invalid_file_normals: self.invalid_file_normals,
            planar: self.planar,
            planar_widened: self.planar_widened,
            linear: self.linear,
            beam_in_plane: self.beam_in_plane,
            scattered: self.scattered,
            too_few_points: self.too_few_points,
        }
    }

    /// Points whose term was left out.
    pub fn left_out(&self) -> u64 {
        self.invalid_file_normals + self.too_few_points
    }

    /// Points whose term is the prior for an unmeasured surface.
    pub fn prior(&self) -> u64 {
        self.beam_in_plane + self.scattered
    }

    /// Points counted.
    pub fn total(&self) -> u64 {
        self.left_out() + self.prior() + self.file_normals + self.planar + self.linear
    }

    /// Warnings when more than a tenth of the points have no incidence term
    /// (`incidence_left_out`), or one that rests on no measured plane (`incidence_assumed`:
    /// a line's across normal or the prior).
    pub fn warnings(&self) -> Vec<Warning> {
        let n = self.total();
        let pc = |v: u64| 100.0 * v as f64 / n.max(1) as f64;
        let mut w = Vec::new();
        let out = self.left_out();
        if n > 0 && out * 10 > n {
            w.push(Warning::new(
                "incidence_left_out",
                format!(
                    "no surface is defined around {out} of {n} points ({:.1} %), so their \
                     incidence term is left out: too few points {:.1} %, invalid file normals \
                     {:.1} %; the vertical sigma of those points lacks the beam-footprint term \
                     (incidence_class 7 and 8 in the output)",
                    pc(out),
                    pc(self.too_few_points),
                    pc(self.invalid_file_normals),
                ),
            ));
        }
        let assumed = self.prior() + self.linear;
        if n > 0 && assumed * 10 > n {
            w.push(Warning::new(
                "incidence_assumed",
                format!(
                    "no plane the beam meets is measured around {assumed} of {n} points ({:.1} \
                     %): linear {:.1} % take the normal across their scan line nearest the \
                     vertical (incidence_class 4); the plane contains the beam (one scan plane) \
                     at {:.1} % and scattered at {:.1} %, which take the incidence of randomly \
                     oriented surfaces, 65.6 degrees (incidence_class 5 and 6); NormalX/Y/Z from \
                     PDAL filters.normal, or more passes over the area, measure it (planar only \
                     when widened: {:.1} %)",
                    pc(assumed),
                    pc(self.linear),
                    pc(self.beam_in_plane),
                    pc(self.scattered),
                    pc(self.planar_widened)
                ),
            ));
        }
        w
    }
}

/// Recovered vs LAS-field scan angle, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AngleCheck {
    /// Points compared.
    pub n: u64,
    /// Σ d², deg².
    pub sum_sq_deg2: f64,
    /// max |d|, deg.
    pub max_deg: f64,
    /// max(|d| − step/2, 0), deg: the disagreement the LAS rounding does not explain.
    pub max_beyond_step_deg: f64,
    /// The LAS field's step, deg (0.006 for formats 6–10, 1 before).
    pub step_deg: f64,
}

impl AngleCheck {
    /// Adds one difference `d` (recovered − LAS, degrees).
    pub fn add(&mut self, d_deg: f64) {
        // An angle difference, wrapped to [−180°, 180°).
        let d_deg = (d_deg + 180.0).rem_euclid(360.0) - 180.0;
        self.n += 1;
        self.sum_sq_deg2 += d_deg * d_deg;
        self.max_deg = self.max_deg.max(d_deg.abs());
        self.max_beyond_step_deg = self
            .max_beyond_step_deg
            .max((d_deg.abs() - self.step_deg / 2.0).max(0.0));
    }
    /// Adds another check.
    pub fn merge(&mut self, o: &AngleCheck) {
        self.n += o.n;
        self.sum_sq_deg2 += o.sum_sq_deg2;
        self.max_deg = self.max_deg.max(o.max_deg);
        self.max_beyond_step_deg = self.max_beyond_step_deg.max(o.max_beyond_step_deg);
        self.step_deg = self.step_deg.max(o.step_deg);
    }
}

/// Distribution of a recovery residual, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResidualCheck {
    /// Points.
    pub n: u64,
    /// Σ q², m².
    pub sum_sq_m2: f64,
    /// max |q|, m.
    pub max_abs_m: f64,
}

impl ResidualCheck {
    /// Adds one residual, m.
    pub fn add(&mut self, q: f64) {
        self.n += 1;
        self.sum_sq_m2 += q * q;
        self.max_abs_m = self.max_abs_m.max(q.abs());
    }
    /// Adds another check.
    pub fn merge(&mut self, o: &ResidualCheck) {
        self.n += o.n;
        self.sum_sq_m2 += o.sum_sq_m2;
        self.max_abs_m = self.max_abs_m.max(o.max_abs_m);
    }
}
