//! The local east-north-up frame where the line geometry is done (the crate docs, step 0).

use crate::Epoch;
use crate::ReturnPoint;
use crate::attitude::wrap;
use lidarqa_io::{Crs, Ellipsoid, Geodetic, TangentFrame, enu_from_ecef};
use lidarqa_model::Enu;
use nalgebra::Vector3;

/// One local east-north-up Cartesian frame, tangent to the ellipsoid at the centre of the
/// returns: where the line geometry is done (module docs, step 0). lidarqa-io's
/// [`TangentFrame`], with the conversions from and to the returns' CRS.
#[derive(Debug, Clone)]
pub struct LocalEnu {
    crs: Crs,
    unit_m: f64,
    ellipsoid: Ellipsoid,
    frame: TangentFrame,
}

impl LocalEnu {
    /// The frame at the mean position of `points` (in `crs`'s units, heights in the same unit).
    pub fn around(crs: Crs, points: &[ReturnPoint]) -> LocalEnu {
        let unit_m = crs.unit().metres();
        let ellipsoid = crs.ellipsoid();
        let n = points.len().max(1) as f64;
        let mean = |k: usize| points.iter().map(|p| p.position_m[k]).sum::<f64>() / n;
        let g = Self::geodetic(&crs, unit_m, [mean(0), mean(1), mean(2)]);
        LocalEnu {
            frame: TangentFrame::at(&ellipsoid, &g),
            crs,
            unit_m,
            ellipsoid,
        }
    }

    fn geodetic(crs: &Crs, unit_m: f64, p: [f64; 3]) -> Geodetic {
        let (latitude_rad, longitude_rad) = crs.inverse(p[0] * unit_m, p[1] * unit_m);
        Geodetic {
            latitude_rad,
            longitude_rad,
            height_m: p[2] * unit_m,
        }
    }

    /// A return in this frame (metres).
    pub fn to_local(&self, p: &ReturnPoint) -> ReturnPoint {
        let g = Self::geodetic(&self.crs, self.unit_m, p.position_m);
        let v = self
            .frame
            .to_enu(&self.ellipsoid.geodetic_to_ecef(&g))
            .vector();
        ReturnPoint {
            position_m: [v.x, v.y, v.z],
            ..*p
        }
    }

    /// An epoch fitted in this frame, back in the CRS: position projected (ellipsoidal height),
    /// pitch and azimuth re-levelled at the epoch, azimuth and velocity turned from true to grid
    /// (velocity in CRS units per second). The σ are in the local east, north, up axes, as
    /// `tpu` reads them, and stay.
    pub fn to_projected(&self, e: &Epoch) -> Epoch {
        let to_ecef = self.frame.enu_from_ecef().transpose();
        let ecef = self
            .frame
            .enu_to_ecef(&Enu::from_vector(Vector3::from(e.position_m)));
        let g = self.ellipsoid.ecef_to_geodetic(&ecef);
        let grid = self.crs.forward(g.latitude_rad, g.longitude_rad);
        // This frame's axes → the local east, north, up at the epoch.
        let relevel = enu_from_ecef(g.latitude_rad, g.longitude_rad) * to_ecef;
        let (sp, cp) = e.pitch_rad.sin_cos();
        let (sa, ca) = e.azimuth_rad.sin_cos();
        let forward = relevel * Vector3::new(cp * sa, cp * ca, sp);
        let (sg, cg) = grid.convergence_rad.sin_cos();
        let v = relevel * Vector3::from(e.velocity_m_per_s);
        // A true direction (east, north) has grid components turned by −γ.
        let v_grid = [cg * v.x - sg * v.y, sg * v.x + cg * v.y, v.z].map(|c| c / self.unit_m);
        Epoch {
            position_m: [
                grid.easting_m / self.unit_m,
                grid.northing_m / self.unit_m,
                g.height_m / self.unit_m,
            ],
            velocity_m_per_s: v_grid,
            pitch_rad: forward.z.clamp(-1.0, 1.0).asin(),
            azimuth_rad: wrap(forward.x.atan2(forward.y) - grid.convergence_rad),
            ..*e
        }
    }
}
