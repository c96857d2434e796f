//! A vegetation layer: tree crowns as boxes on a square grid, so that pulses return from the
//! canopy and again from the ground below it (multi-return pulses, LAS return numbers set).
//!
//! Each grid cell of `crown_m` is a crown or a gap, decided by a hash of the cell index and the
//! layer's seed (not by the pulse RNG), so overlapping strips see the same trees and a scenario
//! without `[scene.vegetation]` draws exactly what it drew before. A crown is a box from its base
//! (40 % of its height) to its top above the ground at the cell centre; a beam that enters a box
//! gives a first return there and goes on (through gaps in the foliage) to the ground, which
//! gives the last return. Crowns are transparent to everything but the beam's own first return:
//! they never hide targets, roofs or water (the scene's other objects are not under trees).

use crate::error::{Error, Result};
use crate::ray::{Curve, Hit};
use serde::{Deserialize, Serialize};

/// ASPRS class of canopy returns (high vegetation).
pub const CLASS_HIGH_VEGETATION: u8 = 5;
/// Reflectivity of foliage at near infrared.
pub const REFLECTIVITY_CANOPY: f64 = 0.45;

/// `[scene.vegetation]`: a forest of box-shaped crowns over the whole scene rectangle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VegetationFile {
    /// Fraction of grid cells that hold a crown, 0–1.
    pub cover_fraction: f64,
    /// Smallest and largest crown top above the ground, m.
    pub canopy_height_m: [f64; 2],
    /// Grid cell (crown) size, m.
    #[serde(default = "default_crown")]
    pub crown_m: f64,
    /// Seed of the crown layout (independent of the scenario seed).
    #[serde(default)]
    pub seed: u64,
}

fn default_crown() -> f64 {
    6.0
}

/// The checked vegetation layer.
#[derive(Debug, Clone, PartialEq)]
pub struct Vegetation {
    /// Fraction of cells with a crown.
    pub cover_fraction: f64,
    /// Smallest and largest crown top above the ground, m.
    pub canopy_height_m: [f64; 2],
    /// Cell size, m.
    pub crown_m: f64,
    /// Layout seed.
    pub seed: u64,
}

/// Crown base as a fraction of the crown top's height above the ground.
const CROWN_BASE_FRACTION: f64 = 0.4;
/// Step of the march through the canopy layer along the beam, m.
const MARCH_STEP_M: f64 = 0.25;

impl Vegetation {
    /// Check a `[scene.vegetation]` table.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] naming the key for a value out of range.
    pub fn from_file(f: &VegetationFile) -> Result<Vegetation> {
        let bad = |key: &str, value: String, reason: &str| Error::InvalidValue {
            key: format!("scene.vegetation.{key}"),
            value,
            reason: reason.into(),
        };
        if !(f.cover_fraction.is_finite() && (0.0..=1.0).contains(&f.cover_fraction)) {
            return Err(bad(
                "cover_fraction",
                f.cover_fraction.to_string(),
                "must be in [0, 1]",
            ));
        }
        let [lo, hi] = f.canopy_height_m;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo && hi <= 100.0) {
            return Err(bad(
                "canopy_height_m",
                format!("[{lo}, {hi}]"),
                "must be [min, max] with 0 < min <= max <= 100 m",
            ));
        }
        if !(f.crown_m.is_finite() && f.crown_m >= 1.0) {
            return Err(bad(
                "crown_m",
                f.crown_m.to_string(),
                "must be at least 1 m",
            ));
        }
        Ok(Vegetation {
            cover_fraction: f.cover_fraction,
            canopy_height_m: f.canopy_height_m,
            crown_m: f.crown_m,
            seed: f.seed,
        })
    }

    /// The crown top above the ground of the cell holding (x, y), m, or `None` for a gap.
    pub fn crown_height_m(&self, x: f64, y: f64) -> Option<f64> {
        let (i, j) = (
            (x / self.crown_m).floor() as i64,
            (y / self.crown_m).floor() as i64,
        );
        let h = hash(self.seed, i, j);
        let u = (h >> 11) as f64 / (1u64 << 53) as f64;
        if u >= self.cover_fraction {
            return None;
        }
        let v = (hash(self.seed ^ 0x9e37_79b9_7f4a_7c15, i, j) >> 11) as f64 / (1u64 << 53) as f64;
        let [lo, hi] = self.canopy_height_m;
        Some(lo + v * (hi - lo))
    }

    /// Centre of the cell holding (x, y), local m.
    fn cell_centre(&self, x: f64, y: f64) -> [f64; 2] {
        let c = self.crown_m;
        [((x / c).floor() + 0.5) * c, ((y / c).floor() + 0.5) * c]
    }

    /// The canopy return of a beam whose last return is `ground` (range along `curve`), if the
    /// beam passes through a crown before it: the first point of the march, in 0.25 m steps from
    /// the top of the tallest crown down to the ground return, that lies inside a crown box.
    /// `ground_height` is the scene's ground height function.
    pub fn canopy_hit(
        &self,
        curve: &Curve,
        ground: &Hit,
        ground_height: impl Fn(f64, f64) -> f64,
    ) -> Option<Hit> {
        let dh = curve.direction(ground.range_m)[2];
        if dh >= 0.0 {
            return None;
        }
        // Range span of the canopy layer above the ground return (the beam is nearly straight
        // over tens of metres).
        let span = self.canopy_height_m[1] / -dh;
        let start = (ground.range_m - span).max(0.0);
        // Leave the last metre to the ground return: a crown base is well above it.
        let end = ground.range_m - 1.0;
        let mut r = start;
        while r < end {
            let p = curve.at(r);
            if let Some(top) = self.crown_height_m(p[0], p[1]) {
                let c = self.cell_centre(p[0], p[1]);
                let g = ground_height(c[0], c[1]);
                let above = p[2] - g;
                if above <= top && above >= CROWN_BASE_FRACTION * top {
                    return Some(Hit {
                        range_m: r,
                        position: p,
                        normal: [0.0, 0.0, 1.0],
                        class: CLASS_HIGH_VEGETATION,
                        reflectivity: REFLECTIVITY_CANOPY,
                    });
                }
            }
            r += MARCH_STEP_M;
        }
        None
    }
}

/// SplitMix64 of the seed and a cell index: a fixed, platform-independent layout.
fn hash(seed: u64, i: i64, j: i64) -> u64 {
    let mut z = seed
        .wrapping_add((i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15))
        .wrapping_add((j as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layer(cover: f64) -> Vegetation {
        Vegetation::from_file(&VegetationFile {
            cover_fraction: cover,
            canopy_height_m: [10.0, 30.0],
            crown_m: 6.0,
            seed: 7,
        })
        .unwrap()
    }

    #[test]
    fn cover_fraction_is_the_share_of_crown_cells() {
        let v = layer(0.6);
        let mut n = 0;
        let mut heights = Vec::new();
        for i in 0..100 {
            for j in 0..100 {
                if let Some(h) = v.crown_height_m(i as f64 * 6.0 + 1.0, j as f64 * 6.0 + 1.0) {
                    n += 1;
                    heights.push(h);
                }
            }
        }
        // Binomial σ of the share over 10⁴ cells is 0.005.
        assert!((n as f64 / 1e4 - 0.6).abs() < 0.02, "{n}");
        assert!(heights.iter().all(|h| (10.0..=30.0).contains(h)));
        let mean = heights.iter().sum::<f64>() / heights.len() as f64;
        assert!((mean - 20.0).abs() < 0.5, "{mean}");
    }

    #[test]
    fn canopy_return_lies_inside_a_crown_above_the_ground_return() {
        let v = layer(1.0);
        let curve = Curve {
            a: [3.0, 3.0, 500.0],
            b: [0.0, 0.0, -1.0],
            c: [0.0; 3],
        };
        let ground = Hit {
            range_m: 500.0,
            position: [3.0, 3.0, 0.0],
            normal: [0.0, 0.0, 1.0],
            class: 2,
            reflectivity: 0.3,
        };
        let hit = v.canopy_hit(&curve, &ground, |_, _| 0.0).unwrap();
        let top = v.crown_height_m(3.0, 3.0).unwrap();
        // A vertical beam meets the top face, within one march step.
        assert!(
            hit.position[2] <= top && hit.position[2] > top - MARCH_STEP_M,
            "{hit:?} top {top}"
        );
        assert!(hit.range_m < ground.range_m);
        assert!(layer(0.0).canopy_hit(&curve, &ground, |_, _| 0.0).is_none());
    }

    #[test]
    fn bad_values_name_the_key() {
        let mut f = VegetationFile {
            cover_fraction: 1.5,
            canopy_height_m: [10.0, 30.0],
            crown_m: 6.0,
            seed: 0,
        };
        let e = Vegetation::from_file(&f).unwrap_err().to_string();
        assert!(e.contains("scene.vegetation.cover_fraction"), "{e}");
        f.cover_fraction = 0.5;
        f.canopy_height_m = [30.0, 10.0];
        let e = Vegetation::from_file(&f).unwrap_err().to_string();
        assert!(e.contains("canopy_height_m"), "{e}");
    }
}
