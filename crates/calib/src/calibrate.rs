//! Self-calibration with the VTPM (Zhang & Jiang 2011, §2.4), observability analysis and the
//! result.

use crate::error::{Error, Result};
use crate::lm::{LmModel, LmOptions, Termination, jacobian, minimize};
use crate::params::{PARAM_COUNT, Param, mounting_from_vector, mounting_to_vector};
use crate::strip::{Strip, check_strips};
use crate::strip_adjust::{
    self, GROUP_NAMES, SigmaTest, StripAdjustment, StripModel, chi2_quantile_99, group_of,
};
use crate::vtpm::{
    DroppedPick, Indexed, NOISE_GROUPS, NedControlPoint, Tie, TieModel, VtpmOptions,
    build_tie_model,
};
use crate::weighting::{
    Column, TrajectorySensitivity, TrajectorySigma, Whitening, group_noise_factors,
};
use lidarqa_model::{Mounting, Ned, Warning};
use lidarqa_products::{
    self as products, CalibrationDocument, CalibrationIterationsDocument, CalibrationTie,
    CalibrationTrajectorySigma, Id, Iteration, Ordered, StripId, TiePosition,
};
use nalgebra::{DMatrix, DVector, Vector3};
use serde_json::Value;

/// Which method produced a calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Virtual tie point model (Zhang & Jiang 2011), lever arm and boresight.
    Vtpm,
    /// Point-to-plane baseline (Attune-like), boresight only.
    Plane,
}

impl Method {
    /// Both methods, the VTPM (the default) first.
    pub const ALL: [Method; 2] = [Method::Vtpm, Method::Plane];

    /// `"vtpm"` or `"plane"` (SPEC §8 `method`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Vtpm => "vtpm",
            Method::Plane => "plane",
        }
    }
}

/// Options of a calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationOptions {
    /// Virtual tie point model options.
    pub vtpm: VtpmOptions,
    /// Adjustment options.
    pub lm: LmOptions,
    /// Which parameters to solve for (order of [`Param::ALL`]); the others stay at the prior.
    pub solve: [bool; PARAM_COUNT],
    /// A pair of parameters whose correlation exceeds this in magnitude is not separable: one of
    /// them is held at its prior (the lever-arm member, which a tape or total station measures at
    /// installation; between two of a kind, the one with the larger σ).
    pub max_correlation: f64,
    /// A lever-arm component whose σ would exceed this is not determined, m.
    pub max_sigma_lever_m: f64,
    /// A boresight angle whose σ would exceed this is not determined, rad.
    pub max_sigma_angle_rad: f64,
    /// Lower bound on the observation σ used in the observability test, m (so that a perfect fit,
    /// σ0 → 0, cannot make every parameter look determined).
    pub sigma_floor_m: f64,
    /// Each strip's constant trajectory error (1-σ): when given, the VTPM adjustment weighs the
    /// ties by it (generalised least squares, [`TrajectorySigma`]) and the σ it reports include it.
    pub trajectory_sigma: Option<TrajectorySigma>,
    /// A-priori 1-σ of each parameter about the prior mounting (SI, [`Param::ALL`] order; `None`:
    /// no prior). A parameter with a prior enters the adjustment as one more observation
    /// `x − x_prior` with that σ: it is never held, a weakly determined one is shrunk toward the
    /// prior with an honest σ, and it is "not observable" when the data alone would not determine
    /// it within [`CalibrationOptions::max_sigma_lever_m`] / `max_sigma_angle_rad`.
    pub prior_sigma: [Option<f64>; PARAM_COUNT],
    /// Estimate per-line trajectory corrections with the mounting ([`crate::StripModel`]);
    /// needs [`CalibrationOptions::trajectory_sigma`] (their priors) and no correlation times.
    pub strip_adjustment: Option<StripModel>,
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        CalibrationOptions {
            vtpm: VtpmOptions::default(),
            lm: LmOptions::default(),
            solve: [true; PARAM_COUNT],
            max_correlation: 0.999,
            max_sigma_lever_m: 0.05,
            max_sigma_angle_rad: 0.01f64.to_radians(),
            sigma_floor_m: 0.01,
            trajectory_sigma: None,
            prior_sigma: [None; PARAM_COUNT],
            strip_adjustment: None,
        }
    }
}

impl CalibrationOptions {
    /// The σ beyond which parameter `p` is not determined (m or rad).
    fn sigma_limit(&self, p: Param) -> f64 {
        if p.is_angle() {
            self.max_sigma_angle_rad
        } else {
            self.max_sigma_lever_m
        }
    }

    /// These options with no parameter ever held for its σ or a correlation: for solves whose
    /// free parameters are already decided (outlier screening, the weighted solves).
    fn holding_nothing(&self) -> CalibrationOptions {
        CalibrationOptions {
            max_sigma_angle_rad: f64::INFINITY,
            max_sigma_lever_m: f64::INFINITY,
            max_correlation: 1.0 + 1e-9,
            ..*self
        }
    }

    fn check(&self) -> Result<()> {
        self.vtpm.check()?;
        let pos = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::InvalidOption {
                    name,
                    expected: "a finite number > 0",
                    value: v,
                })
            }
        };
        pos("max_sigma_lever_m", self.max_sigma_lever_m)?;
        pos("max_sigma_angle_rad", self.max_sigma_angle_rad)?;
        pos("sigma_floor_m", self.sigma_floor_m)?;
        for v in self.prior_sigma.iter().flatten() {
            pos("prior_sigma", *v)?;
        }
        pos("lever_step_m", self.lm.lever_step_m)?;
        pos("angle_step_rad", self.lm.angle_step_rad)?;
        if !(self.max_correlation > 0.0 && self.max_correlation <= 1.0) {
            return Err(Error::InvalidOption {
                name: "max_correlation",
                expected: "in (0, 1]",
                value: self.max_correlation,
            });
        }
        if let Some(t) = &self.trajectory_sigma {
            let names = [
                "trajectory sigma north",
                "trajectory sigma east",
                "trajectory sigma up",
                "trajectory sigma roll",
                "trajectory sigma pitch",
                "trajectory sigma heading",
            ];
            for (name, v) in names
                .into_iter()
                .zip(t.position_m.iter().chain(&t.attitude_rad))
            {
                if !(v.is_finite() && *v >= 0.0) {
                    return Err(Error::InvalidOption {
                        name,
                        expected: "a finite number >= 0",
                        value: *v,
                    });
                }
            }
            for (name, tau) in [
                ("GNSS correlation time", t.position_correlation_s),
                ("attitude correlation time", t.attitude_correlation_s),
            ] {
                if let Some(v) = tau.filter(|v| !(v.is_finite() && *v > 0.0)) {
                    return Err(Error::InvalidOption {
                        name,
                        expected: "a finite number of seconds > 0",
                        value: v,
                    });
                }
            }
        }
        if let Some(m) = self.strip_adjustment {
            let Some(t) = &self.trajectory_sigma else {
                return Err(Error::InvalidStripAdjustment(format!(
                    "{}: the strip adjustment needs the trajectory's sigma (the sensor file's [sigma] gnss_* and roll/pitch/heading) as the corrections' priors",
                    m.name()
                )));
            };
            if t.position_correlation_s.is_some() || t.attitude_correlation_s.is_some() {
                return Err(Error::InvalidStripAdjustment(format!(
                    "{}: the strip adjustment models each line's error as an offset (and drift), not with a correlation time; give one or the other",
                    m.name()
                )));
            }
        }
        if self.lm.max_iterations == 0 {
            return Err(Error::InvalidOption {
                name: "max_iterations",
                expected: "at least 1",
                value: 0.0,
            });
        }
        Ok(())
    }
}

/// Lower bound on the ties' own noise in the trajectory weighting, m: a near-perfect fit must not
/// make the trajectory's share look infinitely larger than the ties'.
const MIN_TIE_SIGMA_M: f64 = 0.002;

/// One tie's residuals before and after the adjustment.
#[derive(Debug, Clone, PartialEq)]
pub struct TieReport {
    /// The tie's (or control point's) id.
    pub id: String,
    /// The strips it was observed in.
    pub strips: Vec<String>,
    /// True when the tie observes a control point (residuals are then tie − control).
    pub control: bool,
    /// Per-axis RMS over the tie's strips of (tie coordinate − reference) at the prior, m,
    /// `[east, north, up]` in the local level frame; the reference is the mean over the strips
    /// (Zhang & Jiang 2011, eq. 7) or the control point.
    pub residual_before_m: [f64; 3],
    /// The same after the adjustment, m.
    pub residual_after_m: [f64; 3],
}

/// Parameters and tie coordinates at one iteration (the data of Zhang & Jiang (2011) Fig. 9).
#[derive(Debug, Clone, PartialEq)]
pub struct IterationRecord {
    /// 0 = the prior; k = after the k-th accepted step.
    pub iteration: usize,
    /// The mounting at this iteration (SI, [`Param::ALL`] order).
    pub parameters: [f64; PARAM_COUNT],
    /// Each tie's coordinate (mean over its strips, Zhang & Jiang (2011) eq. 7), in the
    /// calibration's frame `L`.
    pub ties: Vec<(String, Ned)>,
}

/// The result of a calibration: SPEC §8 `calibration.json` is [`Calibration::to_document`].
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The method used.
    pub method: Method,
    /// The prior (nominal) mounting the strips were georeferenced with.
    pub prior: Mounting,
    /// The calibrated mounting; parameters not observable are at the prior.
    pub mounting: Mounting,
    /// A-posteriori 1-σ, `σ0 · √diag(N⁻¹)` (with the trajectory weighting: the ties' estimated
    /// noises, or σ0 if larger), SI (m, rad); `None` for a parameter held at its prior.
    pub sigma: [Option<f64>; PARAM_COUNT],
    /// Correlation matrix of the solved parameters; `None` where either parameter is held.
    pub correlation: [[Option<f64>; PARAM_COUNT]; PARAM_COUNT],
    /// Whether each parameter was determined by the data (SPEC §8 `observable`).
    pub observable: [bool; PARAM_COUNT],
    /// Why each held parameter was held (empty for solved ones).
    pub held_because: [String; PARAM_COUNT],
    /// Accepted iterations of the final solve.
    pub iterations: usize,
    /// Why the final solve stopped.
    pub termination: Termination,
    /// A-posteriori σ of unit weight (an observation's σ), m; with the trajectory weighting, of
    /// the whitened residuals, in metres of the unweighted fit's σ0.
    pub sigma0_m: f64,
    /// Redundancy: independent observations − solved unknowns.
    pub redundancy: usize,
    /// Per-tie residuals before and after.
    pub ties: Vec<TieReport>,
    /// Convergence record of the final solve.
    pub history: Vec<IterationRecord>,
    /// Control points inside the strips that no strip could triangulate, left out.
    pub skipped_control: Vec<String>,
    /// The per-strip trajectory σ the ties were weighted with, when they were.
    pub trajectory_sigma: Option<TrajectorySigma>,
    /// The a-priori σ each parameter entered with (SI; `None`: no prior).
    pub prior_sigma: [Option<f64>; PARAM_COUNT],
    /// Picks no virtual tie could be formed from in their strip, left out (SPEC §8).
    pub dropped_picks: Vec<DroppedPick>,
    /// Doubtful findings about the inputs (one per dropped pick, ...), for the CLI to print.
    pub warnings: Vec<Warning>,
    /// The per-line trajectory corrections, when the strip adjustment ran.
    pub strip_adjustment: Option<StripAdjustment>,
}

fn enu(v: &Vector3<f64>) -> [f64; 3] {
    [v.y, v.x, -v.z]
}

/// One value per parameter, keyed as in `calibration.json`, in [`Param::ALL`] order.
fn param_map<V>(f: impl Fn(Param) -> V) -> Ordered<V> {
    Param::ALL
        .iter()
        .map(|&p| (p.key().to_string(), f(p)))
        .collect()
}

impl Calibration {
    /// SPEC §8 `calibration.json`: `method`, `parameters` (the calibrated mounting, keys with unit
    /// suffixes, degrees and metres), `sigma` (same keys, `null` when held), `correlation` (6 × 6 in
    /// key order, `null` where a parameter is held), `observable`, `iterations`, `ties`
    /// (`residual_*_m` as `[east, north, up]` per-axis RMS, m).
    pub fn to_document(&self) -> CalibrationDocument {
        let x = mounting_to_vector(&self.mounting);
        let display = |p: Param, v: Option<f64>| v.map(|s| p.to_display(s));
        let with_prior = self.prior_sigma.iter().any(Option::is_some);
        CalibrationDocument {
            method: Some(self.method.name().to_string()),
            parameters: param_map(|p| p.to_display(x[p.index()])),
            sigma: param_map(|p| display(p, self.sigma[p.index()])),
            correlation: self.correlation.iter().map(|row| row.to_vec()).collect(),
            observable: param_map(|p| self.observable[p.index()]),
            iterations: Some(self.iterations as u64),
            ties: self
                .ties
                .iter()
                .map(|t| CalibrationTie {
                    id: Id(t.id.clone()),
                    strips: t.strips.iter().map(|s| StripId(s.clone())).collect(),
                    residual_before_m: Some(t.residual_before_m),
                    residual_after_m: Some(t.residual_after_m),
                })
                .collect(),
            prior_sigma: with_prior.then(|| param_map(|p| display(p, self.prior_sigma[p.index()]))),
            // 1 − posterior σ / prior σ: how much the data reduced each prior's σ.
            sigma_reduction_by_data: with_prior.then(|| {
                param_map(
                    |p| match (self.prior_sigma[p.index()], self.sigma[p.index()]) {
                        (Some(sp), Some(s)) => Some(1.0 - s / sp),
                        _ => None,
                    },
                )
            }),
            dropped_picks: (self.method == Method::Vtpm).then(|| {
                self.dropped_picks
                    .iter()
                    .map(|d| products::DroppedPick {
                        tie: Id(d.tie.clone()),
                        strip: StripId(d.strip.clone()),
                        reason: d.reason.clone(),
                    })
                    .collect()
            }),
            warnings: self.warnings.clone(),
            strip_adjustment: self
                .strip_adjustment
                .as_ref()
                .map(StripAdjustment::to_block),
            // Beyond SPEC §8, only when it happened: control points no strip could triangulate.
            skipped_control: (!self.skipped_control.is_empty())
                .then(|| self.skipped_control.clone()),
            // Beyond SPEC §8: the trajectory σ the ties were weighted with (and `sigma` includes).
            trajectory_sigma: self
                .trajectory_sigma
                .as_ref()
                .map(|t| CalibrationTrajectorySigma {
                    gnss_north_m: t.position_m[0],
                    gnss_east_m: t.position_m[1],
                    gnss_up_m: t.position_m[2],
                    roll_deg: t.attitude_rad[0].to_degrees(),
                    pitch_deg: t.attitude_rad[1].to_degrees(),
                    heading_deg: t.attitude_rad[2].to_degrees(),
                    gnss_correlation_s: t.position_correlation_s,
                    attitude_correlation_s: t.attitude_correlation_s,
                }),
            lines: None,
        }
    }

    /// [`Calibration::to_document`] as JSON.
    pub fn to_json(&self) -> Value {
        serde_json::to_value(self.to_document()).unwrap_or(Value::Null)
    }

    /// `calibration_iterations.json`; `to_output` maps a position in the calibration's frame `L`
    /// to the output coordinates (e.g. projected easting, northing, height; [`local_enu`] for the
    /// local frame).
    pub fn iterations_document(
        &self,
        to_output: impl Fn(&Ned) -> [f64; 3],
    ) -> CalibrationIterationsDocument {
        CalibrationIterationsDocument {
            iterations: self
                .history
                .iter()
                .map(|it| Iteration {
                    iteration: it.iteration as u64,
                    parameters: param_map(|p| p.to_display(it.parameters[p.index()])),
                    ties: it
                        .ties
                        .iter()
                        .map(|(id, v)| TiePosition {
                            id: Id(id.clone()),
                            xyz_m: to_output(v),
                        })
                        .collect(),
                })
                .collect(),
        }
    }

    /// [`Calibration::iterations_document`] as JSON.
    pub fn iterations_json(&self, to_output: impl Fn(&Ned) -> [f64; 3]) -> Value {
        serde_json::to_value(self.iterations_document(to_output)).unwrap_or(Value::Null)
    }

    /// Overall RMS of the tie residuals `(horizontal, vertical)` before and after, m:
    /// `√(mean(e² + n²))` and `√(mean(u²))` over ties.
    pub fn tie_rms_m(&self) -> ((f64, f64), (f64, f64)) {
        let rms = |f: &dyn Fn(&TieReport) -> [f64; 3]| {
            let n = self.ties.len().max(1) as f64;
            let h = self
                .ties
                .iter()
                .map(|t| {
                    let r = f(t);
                    r[0] * r[0] + r[1] * r[1]
                })
                .sum::<f64>();
            let v = self.ties.iter().map(|t| f(t)[2].powi(2)).sum::<f64>();
            ((h / n).sqrt(), (v / n).sqrt())
        };
        (rms(&|t| t.residual_before_m), rms(&|t| t.residual_after_m))
    }
}

/// Local NED → `[east, north, up]`, m: the default output mapping of
/// [`Calibration::iterations_json`].
pub fn local_enu(v: &Ned) -> [f64; 3] {
    enu(&v.vector())
}

/// Reads the calibrated mounting from a SPEC §8 `calibration.json` document.
///
/// # Errors
/// [`Error::InvalidCalibration`] naming the missing or non-numeric key.
pub fn mounting_from_json(doc: &Value) -> Result<Mounting> {
    let params = doc
        .get("parameters")
        .and_then(Value::as_object)
        .ok_or_else(|| Error::InvalidCalibration("no \"parameters\" object".into()))?;
    let mut x = [0.0; PARAM_COUNT];
    for p in Param::ALL {
        let v = params
            .get(p.key())
            .and_then(Value::as_f64)
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                Error::InvalidCalibration(format!(
                    "parameters.{} is missing or not a number",
                    p.key()
                ))
            })?;
        x[p.index()] = p.from_display(v);
    }
    Ok(mounting_from_vector(&x))
}

/// The strips of a calibration: two or more, each valid ([`check_strips`]), each overlapping
/// another.
pub(crate) fn check_calibration_strips(strips: &[Strip]) -> Result<()> {
    if strips.len() < 2 {
        return Err(Error::TooFewStrips {
            what: "calibration",
            needed: 2,
            got: strips.len(),
        });
    }
    check_strips(strips)?;
    check_overlap(strips)
}

/// Strip extents must each meet another's.
pub(crate) fn check_overlap(strips: &[Strip]) -> Result<()> {
    let ext: Vec<[f64; 4]> = strips.iter().filter_map(Strip::extent_m).collect();
    for (i, a) in ext.iter().enumerate() {
        let meets = ext
            .iter()
            .enumerate()
            .any(|(j, b)| j != i && a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3]);
        if !meets {
            return Err(Error::NoOverlap {
                strip: strips[i].id.clone(),
            });
        }
    }
    Ok(())
}

/// The VTPM as an [`LmModel`].
#[derive(Clone)]
struct VtpmProblem<'a> {
    strips: &'a [Strip],
    model: TieModel,
    /// The trajectory weighting, when on: residuals are whitened by it.
    whitening: Option<Whitening>,
}

impl LmModel for VtpmProblem<'_> {
    fn residuals(&self, x: &[f64; PARAM_COUNT]) -> Vec<f64> {
        let r = self
            .model
            .residuals_from(&self.model.coords_at(self.strips, x));
        match &self.whitening {
            Some(w) => w.apply(r),
            None => r,
        }
    }
    fn accept(&mut self, x: &[f64; PARAM_COUNT]) {
        self.model.accept(self.strips, x);
    }
}

/// The outcome of the solve-and-check loop shared by both methods.
pub(crate) struct Solved<M> {
    pub(crate) x: [f64; PARAM_COUNT],
    pub(crate) model: M,
    pub(crate) iterations: usize,
    pub(crate) termination: Termination,
    pub(crate) sigma: [Option<f64>; PARAM_COUNT],
    pub(crate) correlation: [[Option<f64>; PARAM_COUNT]; PARAM_COUNT],
    pub(crate) observable: [bool; PARAM_COUNT],
    pub(crate) held_because: [String; PARAM_COUNT],
    pub(crate) sigma0_m: f64,
    pub(crate) redundancy: usize,
    pub(crate) history: Vec<([f64; PARAM_COUNT], M)>,
    /// The residuals at the solution (the model's, then the prior rows).
    pub(crate) residuals: Vec<f64>,
    /// The Jacobian of `residuals` over the free parameters at the solution.
    pub(crate) jacobian: DMatrix<f64>,
    /// The (pseudo-)inverse of `jacobianᵀ jacobian`.
    pub(crate) inverse_normal: DMatrix<f64>,
    /// Parameters held at the prior (never one with a prior σ).
    pub(crate) held: [bool; PARAM_COUNT],
    /// Per held parameter: how far the solved ones move per unit error in it,
    /// `−N⁻¹ Jᵀ j_held` (zero for the held ones); `None` for a solved parameter.
    pub(crate) held_shift: [Option<[f64; PARAM_COUNT]>; PARAM_COUNT],
}

impl<M> Solved<M> {
    /// The calibration this solution is, with the method's `ties`; no history, skipped control,
    /// trajectory weighting, dropped picks or warnings (the VTPM adds its own).
    pub(crate) fn into_calibration(
        self,
        method: Method,
        prior: &Mounting,
        options: &CalibrationOptions,
        ties: Vec<TieReport>,
    ) -> Calibration {
        Calibration {
            method,
            prior: *prior,
            mounting: mounting_from_vector(&self.x),
            sigma: self.sigma,
            correlation: self.correlation,
            observable: self.observable,
            held_because: self.held_because,
            iterations: self.iterations,
            termination: self.termination,
            sigma0_m: self.sigma0_m,
            redundancy: self.redundancy,
            ties,
            history: Vec::new(),
            skipped_control: Vec::new(),
            trajectory_sigma: None,
            prior_sigma: std::array::from_fn(|i| {
                options.prior_sigma[i].filter(|_| options.solve[i])
            }),
            dropped_picks: Vec::new(),
            warnings: Vec::new(),
            strip_adjustment: None,
        }
    }
}

/// A model with prior observations appended: row `i` is `(x_i − x_prior_i) · weight_i`, where
/// `weight_i = σ_obs / σ_prior_i` puts it on the scale of the model's own residuals.
#[derive(Clone)]
struct WithPriors<M> {
    inner: M,
    prior: [f64; PARAM_COUNT],
    weight: [f64; PARAM_COUNT],
}

impl<M: LmModel> LmModel for WithPriors<M> {
    fn residuals(&self, x: &[f64; PARAM_COUNT]) -> Vec<f64> {
        let mut r = self.inner.residuals(x);
        for ((xi, pi), wi) in x.iter().zip(&self.prior).zip(&self.weight) {
            if *wi > 0.0 {
                r.push((xi - pi) * wi);
            }
        }
        r
    }
    fn accept(&mut self, x: &[f64; PARAM_COUNT]) {
        self.inner.accept(x);
    }
}

/// Solves, analyses observability at the solution, holds what is not determined or not separable
/// and solves again, until every solved parameter is determined.
///
/// Parameters with a prior σ ([`CalibrationOptions::prior_sigma`]) are never held: their prior
/// rows are scaled by `prior_scale_m`, the σ of one of the model's residuals (the tie noise the
/// weighted model is whitened with), or, when `None`, by the σ0 of a first solve without priors.
///
/// With `prior_scale_m` the model's residuals are whitened by noises estimated beforehand, so
/// the reported σ scale by it rather than by σ0 (σ0 only if larger): a noise group held at its
/// floor ([`MIN_TIE_SIGMA_M`]) fits better than its σ and would otherwise shrink every σ, also
/// those its rows do not determine.
pub(crate) fn solve_with_observability<M: LmModel + Clone>(
    initial: &M,
    prior: [f64; PARAM_COUNT],
    observations: usize,
    opts: &CalibrationOptions,
    keep_history: bool,
    prior_scale_m: Option<f64>,
) -> Result<Solved<M>> {
    let has_prior: [bool; PARAM_COUNT] =
        std::array::from_fn(|i| opts.solve[i] && opts.prior_sigma[i].is_some());
    let any_prior = has_prior.iter().any(|b| *b);
    let mut scale = prior_scale_m.filter(|_| any_prior);
    let mut held_because: [String; PARAM_COUNT] = Default::default();
    for p in Param::ALL {
        if !opts.solve[p.index()] {
            held_because[p.index()] = "not solved for (by request)".into();
        }
    }
    // The observation σ the decisions use is the first solve's (every requested parameter
    // free): a parameter held at a wrong prior worsens the fit, and judging the rest by that
    // worse σ0 would hold them one after another.
    let mut decision_sigma0: Option<f64> = None;
    loop {
        let free: Vec<usize> = (0..PARAM_COUNT)
            .filter(|&i| held_because[i].is_empty())
            .collect();
        if free.is_empty() {
            let reasons: Vec<String> = Param::ALL
                .iter()
                .map(|p| format!("{}: {}", p.key(), held_because[p.index()]))
                .collect();
            return Err(Error::NothingDetermined(reasons.join("; ")));
        }
        let weight: [f64; PARAM_COUNT] =
            std::array::from_fn(|i| match (scale, opts.prior_sigma[i]) {
                (Some(s), Some(sp)) if has_prior[i] && held_because[i].is_empty() => s / sp,
                _ => 0.0,
            });
        let prior_rows = weight.iter().filter(|w| **w > 0.0).count();
        if observations + prior_rows < free.len().max(1) {
            return Err(Error::TooFewTies {
                ties: 0,
                observations,
                unknowns: free.len(),
                dropped: Vec::new(),
            });
        }
        let mut model = WithPriors {
            inner: initial.clone(),
            prior,
            weight,
        };
        let mut history = Vec::new();
        let out = minimize(&mut model, prior, &free, &opts.lm, |_, x, m| {
            if keep_history {
                history.push((*x, m.inner.clone()));
            }
        });
        if !out.x.iter().all(|v| v.is_finite()) {
            return Err(Error::Diverged(format!("parameters {:?}", out.x)));
        }
        let r = model.residuals(&out.x);
        let redundancy = (observations + prior_rows).saturating_sub(free.len());
        let sigma0 = (r.iter().map(|v| v * v).sum::<f64>() / redundancy.max(1) as f64).sqrt();
        if any_prior && scale.is_none() {
            // The priors' scale: the observation σ of a first solve on the data alone.
            scale = Some(sigma0.max(MIN_TIE_SIGMA_M));
            decision_sigma0 = Some(sigma0);
            continue;
        }
        let j = jacobian(&model, &out.x, &free, &opts.lm, r.len());
        let n = j.transpose() * &j;
        let e = n.clone().symmetric_eigen();
        let lmax = e.eigenvalues.iter().cloned().fold(0.0, f64::max);
        // Pseudo-inverse: directions with ~no information are infinitely uncertain.
        let k = free.len();
        let mut inv = DMatrix::zeros(k, k);
        let mut null_weight = vec![0.0; k];
        for c in 0..k {
            let l = e.eigenvalues[c];
            let v = e.eigenvectors.column(c);
            if l <= 1e-12 * lmax || l <= 0.0 {
                for a in 0..k {
                    null_weight[a] += v[a] * v[a];
                }
            } else {
                inv += v * v.transpose() / l;
            }
        }
        let sigma_obs = decision_sigma0
            .get_or_insert(sigma0)
            .max(opts.sigma_floor_m);
        // Hold only the least determined parameter (σ furthest beyond its limit), then solve
        // again: with a near-null one held (lever z without control), the others' σ shrink.
        let mut worst_sigma: Option<(usize, f64, f64)> = None;
        for (c, &i) in free.iter().enumerate() {
            if has_prior[i] {
                continue;
            }
            let p = Param::ALL[i];
            let s = if null_weight[c] > 1e-6 {
                f64::INFINITY
            } else {
                sigma_obs * inv[(c, c)].sqrt()
            };
            let limit = opts.sigma_limit(p);
            let excess = if s.is_nan() { f64::INFINITY } else { s / limit };
            if excess > 1.0 && worst_sigma.is_none_or(|(_, _, e)| excess > e) {
                worst_sigma = Some((i, s, excess));
            }
        }
        if let Some((i, s, _)) = worst_sigma {
            let p = Param::ALL[i];
            let limit = opts.sigma_limit(p);
            held_because[i] = if s.is_finite() {
                format!(
                    "not determined: sigma {:.4} {} exceeds {:.4}",
                    p.to_display(s),
                    if p.is_angle() { "deg" } else { "m" },
                    p.to_display(limit)
                )
            } else {
                "not determined: the ties carry no information on it".into()
            };
            continue;
        }
        // Correlations among the determined parameters.
        let mut worst: Option<(usize, usize, f64)> = None;
        for a in 0..k {
            for b in a + 1..k {
                let rho = inv[(a, b)] / (inv[(a, a)] * inv[(b, b)]).sqrt();
                if !has_prior[free[a]]
                    && !has_prior[free[b]]
                    && rho.abs() > opts.max_correlation
                    && worst.is_none_or(|(_, _, w)| rho.abs() > w.abs())
                {
                    worst = Some((a, b, rho));
                }
            }
        }
        if let Some((a, b, rho)) = worst {
            let (pa, pb) = (Param::ALL[free[a]], Param::ALL[free[b]]);
            let rel = |c: usize, p: Param| inv[(c, c)].sqrt() / opts.sigma_limit(p);
            let hold = match (pa.is_angle(), pb.is_angle()) {
                (false, true) => a,
                (true, false) => b,
                _ if rel(a, pa) >= rel(b, pb) => a,
                _ => b,
            };
            let other = if hold == a { pb } else { pa };
            held_because[free[hold]] = format!(
                "not separable from {}: correlation {rho:.3} exceeds {}",
                other.key(),
                opts.max_correlation
            );
            continue;
        }
        let mut sigma = [None; PARAM_COUNT];
        let mut correlation = [[None; PARAM_COUNT]; PARAM_COUNT];
        let sigma_scale = prior_scale_m.map_or(sigma0, |s| s.max(sigma0));
        for (a, &i) in free.iter().enumerate() {
            sigma[i] = Some(sigma_scale * inv[(a, a)].sqrt());
            for (b, &jj) in free.iter().enumerate() {
                correlation[i][jj] = Some(if a == b {
                    1.0
                } else {
                    inv[(a, b)] / (inv[(a, a)] * inv[(b, b)]).sqrt()
                });
            }
        }
        let prior_ratio: [Option<f64>; PARAM_COUNT] =
            std::array::from_fn(|i| match (sigma[i], opts.prior_sigma[i]) {
                (Some(s), Some(sp)) if has_prior[i] => Some(s / sp),
                _ => None,
            });
        let held: [bool; PARAM_COUNT] = std::array::from_fn(|i| !held_because[i].is_empty());
        for (i, q) in prior_ratio.iter().enumerate() {
            let (Some(q), Some(sp)) = (*q, opts.prior_sigma[i]) else {
                continue;
            };
            // What the data alone determine: 1/σ² = 1/σ_prior² + 1/σ_data².
            let sigma_data = sp / (1.0 / (q * q) - 1.0).max(0.0).sqrt();
            let p = Param::ALL[i];
            if sigma_data.is_nan() || sigma_data > opts.sigma_limit(p) {
                let unit = if p.is_angle() { "deg" } else { "m" };
                held_because[i] = format!(
                    "not observable: the data alone determine it to {} only (limit {:.4} {unit}); they reduce its prior sigma {:.4} {unit} by {:.1} %, so value and sigma are mostly the prior's",
                    if sigma_data.is_finite() {
                        format!("{:.4} {unit}", p.to_display(sigma_data))
                    } else {
                        "nothing".to_string()
                    },
                    p.to_display(opts.sigma_limit(p)),
                    p.to_display(sp),
                    100.0 * (1.0 - q)
                );
            }
        }
        let observable = std::array::from_fn(|i| held_because[i].is_empty());
        let mut held_shift = [None; PARAM_COUNT];
        for h in (0..PARAM_COUNT).filter(|&h| held[h]) {
            let jh = jacobian(&model, &out.x, &[h], &opts.lm, r.len());
            let shift = -(&inv * (j.transpose() * jh.column(0)));
            let mut full = [0.0; PARAM_COUNT];
            for (a, &i) in free.iter().enumerate() {
                full[i] = shift[a];
            }
            held_shift[h] = Some(full);
        }
        return Ok(Solved {
            held,
            held_shift,
            x: out.x,
            model: model.inner,
            iterations: out.iterations,
            termination: out.termination,
            sigma,
            correlation,
            observable,
            held_because,
            sigma0_m: sigma0,
            redundancy,
            history,
            residuals: r,
            jacobian: j,
            inverse_normal: inv,
        });
    }
}

fn per_axis_rms(
    coords: &[Vector3<f64>],
    reference: &Vector3<f64>,
    directions: &[Vector3<f64>],
) -> [f64; 3] {
    // Only the observed directions count: project each difference on them first.
    let mut acc = [0.0; 3];
    for c in coords {
        let d = c - reference;
        let proj: Vector3<f64> = directions.iter().map(|u| u * u.dot(&d)).sum();
        let e = enu(&proj);
        for k in 0..3 {
            acc[k] += e[k] * e[k];
        }
    }
    acc.map(|a| (a / coords.len().max(1) as f64).sqrt())
}

pub(crate) fn tie_reports(strips: &[Strip], before: &TieModel, after: &TieModel) -> Vec<TieReport> {
    before
        .ties
        .iter()
        .zip(&after.ties)
        .map(|(b, a)| {
            let rep = |t: &crate::vtpm::TieSpec| {
                let c: Vec<Vector3<f64>> = t.virtuals.iter().map(|v| v.coord).collect();
                let reference = t
                    .control
                    .unwrap_or_else(|| c.iter().sum::<Vector3<f64>>() / c.len() as f64);
                per_axis_rms(&c, &reference, &t.directions)
            };
            TieReport {
                id: b.id.clone(),
                strips: b
                    .virtuals
                    .iter()
                    .map(|v| strips[v.strip].id.clone())
                    .collect(),
                control: b.control.is_some(),
                residual_before_m: rep(b),
                residual_after_m: rep(a),
            }
        })
        .collect()
}

fn tie_means(model: &TieModel) -> Vec<(String, Ned)> {
    model
        .ties
        .iter()
        .map(|t| {
            let c = t.virtuals.iter().map(|v| v.coord).sum::<Vector3<f64>>();
            (t.id.clone(), Ned::from_vector(c / t.virtuals.len() as f64))
        })
        .collect()
}

/// Boresight and lever-arm self-calibration with the virtual tie point model (Zhang & Jiang 2011,
/// §2.4).
///
/// Steps: virtual ties for every pick and control point (rule 1 heights at the `prior`), then
/// Levenberg–Marquardt on the residuals *tie coordinate − mean over its strips* (eq. 7–8; *tie −
/// control* for control points), with rule 2 carrying the ties between iterations and a
/// central-difference Jacobian. At the solution the normal matrix `N = JᵀJ` is examined: a
/// parameter whose σ (with the observation σ at least [`CalibrationOptions::sigma_floor_m`])
/// exceeds its limit, or one of a pair correlated beyond
/// [`CalibrationOptions::max_correlation`], is reported not observable, held at the prior, and
/// the rest solved again.
///
/// # Errors
/// Fewer than two strips, empty or duplicate strips, a strip overlapping no other
/// ([`Error::NoOverlap`]), a pick in an unknown strip, outside its strip or with no coplanar
/// triangle, a control point outside every strip, fewer independent observations than unknowns
/// ([`Error::TooFewTies`]), an invalid option.
pub fn calibrate_vtpm(
    strips: &[Strip],
    ties: &[Tie],
    control: &[NedControlPoint],
    prior: &Mounting,
    options: &CalibrationOptions,
) -> Result<Calibration> {
    options.check()?;
    check_calibration_strips(strips)?;
    let x0 = mounting_to_vector(prior);
    let idx = Indexed::new(strips, options.vtpm.radius_m.max(0.5));
    let mut model = build_tie_model(&idx, ties, control, &x0, &options.vtpm)?;
    let warnings: Vec<Warning> = model
        .dropped_picks
        .iter()
        .map(|d| {
            Warning::new(
                "tie_pick_dropped",
                format!(
                    "tie {}: the pick in strip {} is left out: {}",
                    d.tie, d.strip, d.reason
                ),
            )
        })
        .chain(model.plain_ties.iter().map(|t| {
            Warning::new(
                "tie_on_plain_surface",
                format!(
                    "tie {t}: every strip shows one plain plane around the picks (no edge or \
                     marking), so only its position across that plane is used, not where on it \
                     it was picked"
                ),
            )
        }))
        .collect();
    screen_outlier_ties(strips, &mut model, x0, options);
    let observations = model.observations();
    let unknowns = options.solve.iter().filter(|s| **s).count();
    if observations < unknowns {
        return Err(Error::TooFewTies {
            ties: model.ties.len(),
            observations,
            unknowns,
            dropped: model.dropped_picks.clone(),
        });
    }
    let mut problem = VtpmProblem {
        strips,
        model: model.clone(),
        whitening: None,
    };
    let mut strip_result: Option<StripAdjustment> = None;
    let solved = match &options.trajectory_sigma {
        None => solve_with_observability(&problem, x0, observations, options, true, None)?,
        Some(ts) => {
            // What is determined is decided on the unweighted fit, by the same rules as without
            // the weighting (its σ0 holds the trajectory's share, so this is the cautious
            // choice); the weighted solves then free exactly those parameters and report σ that
            // include the trajectory. A parameter the weighting alone would call determined is
            // not trusted: the weighting models the trajectory, not a tie's systematic error.
            let geometry =
                solve_with_observability(&problem, x0, observations, options, false, None)?;
            let weighted = CalibrationOptions {
                solve: geometry.held.map(|h| !h),
                ..options.holding_nothing()
            };
            let not_finite = || Error::Diverged("the trajectory weighting is not finite".into());
            let drift = options.strip_adjustment.is_some_and(StripModel::drift);
            let base = TrajectorySensitivity::with_drift(strips, &model, &x0, ts, drift)
                .ok_or_else(not_finite)?;
            // The ties' own noise is not known in advance, and a pick's horizontal position
            // and a surface's height have different ones (`NoiseGroup`): start both from the
            // unweighted fit's σ0 (which still holds the trajectory's share) and re-estimate
            // each group's σ from its own weighted residuals until they agree with what the
            // whitening assumed (variance components). Stopping early would scale the
            // trajectory's part of the reported σ by σ0/σ_t; one σ for both groups made the σ
            // of what the horizontal rows determine (yaw) too small by the nearly exact
            // heights' share of the pool.
            let reference_m = geometry.sigma0_m.max(MIN_TIE_SIGMA_M);
            let groups = model.row_groups();
            let group_observations = model.group_observations();
            let mut group_sigma_m = [reference_m; NOISE_GROUPS];
            // With the strip adjustment, the trajectory's σ per group (GNSS position, attitude)
            // is scaled by the data too, in an outer loop (module docs of `strip_adjust`).
            let mut trajectory_factor = [1.0f64; 2];
            let mut first_tests: Option<[(f64, f64); 2]> = None;
            let mut outer = 1;
            let mut solved = loop {
                // The factors this solve uses (the test below may update them).
                let used = trajectory_factor;
                let sensitivity = base.scaled(|c| match c {
                    Column::Line { component, .. } => used[group_of(*component)],
                    Column::Other => 1.0,
                });
                let mut pass = 1;
                let fit = loop {
                    let rows: Vec<f64> =
                        groups.iter().map(|g| group_sigma_m[*g as usize]).collect();
                    let w = sensitivity
                        .whitening(&rows, reference_m)
                        .ok_or_else(not_finite)?;
                    problem.whitening = Some(w.clone());
                    let fit = solve_with_observability(
                        &problem,
                        x0,
                        observations,
                        &weighted,
                        true,
                        Some(reference_m),
                    )?;
                    let factors = group_noise_factors(
                        &w,
                        &groups,
                        &group_observations,
                        &fit.jacobian,
                        &fit.inverse_normal,
                        &fit.residuals,
                        reference_m,
                    );
                    let mut agreed = true;
                    for (sigma_m, factor) in group_sigma_m.iter_mut().zip(factors) {
                        let Some(f) = factor else { continue };
                        let next = (*sigma_m * f).max(MIN_TIE_SIGMA_M);
                        agreed &= (next - *sigma_m).abs() <= NOISE_AGREEMENT * *sigma_m;
                        *sigma_m = next;
                    }
                    if agreed || pass == MAX_NOISE_PASSES {
                        break fit;
                    }
                    pass += 1;
                };
                let Some(strip_model) = options.strip_adjustment else {
                    break fit;
                };
                let rows: Vec<f64> = groups.iter().map(|g| group_sigma_m[*g as usize]).collect();
                let free: Vec<usize> = (0..PARAM_COUNT).filter(|&i| !fit.held[i]).collect();
                let raw = VtpmProblem {
                    strips,
                    model: fit.model.model.clone(),
                    whitening: None,
                };
                let r = raw.residuals(&fit.x);
                let j = jacobian(&raw, &fit.x, &free, &options.lm, r.len());
                let prior_info: Vec<f64> = free
                    .iter()
                    .map(|&i| options.prior_sigma[i].map_or(0.0, |s| 1.0 / (s * s)))
                    .collect();
                let joint = strip_adjust::joint(&j, sensitivity.matrix(), &rows, &r, &prior_info)
                    .ok_or_else(|| {
                    Error::Diverged("the strip adjustment is singular".into())
                })?;
                let stats = strip_adjust::group_statistics(&joint, &sensitivity.labels, free.len());
                let first = *first_tests.get_or_insert(stats);
                let mut agreed = true;
                for (g, (t, red)) in stats.iter().enumerate() {
                    // Scaled only up: smaller residuals than declared are no reason to trust the
                    // trajectory more. Scaled whenever the data show more than declared, not
                    // only once the χ² test failed: with four lines the attitude's redundancy is
                    // ~2.5, and a test of that power let 0.005° attitude errors through at a
                    // declared 0.002° on four seeds of ten (the mounting's σ then 3–5 times too
                    // small). The warning is for a failed test only.
                    if *red <= 0.5 {
                        continue;
                    }
                    let f = (t / red).sqrt();
                    if f.is_finite() {
                        let next = (trajectory_factor[g] * f).max(1.0);
                        agreed &= (next - trajectory_factor[g]).abs()
                            <= TRAJECTORY_AGREEMENT * trajectory_factor[g];
                        trajectory_factor[g] = next;
                    }
                }
                if !agreed && outer < MAX_TRAJECTORY_PASSES {
                    outer += 1;
                    continue;
                }
                let spans: Vec<(String, [f64; 2])> = strips
                    .iter()
                    .map(|s| {
                        let span = s
                            .points
                            .iter()
                            .fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], p| {
                                [a.min(p.time_s), b.max(p.time_s)]
                            });
                        (s.id.clone(), span)
                    })
                    .collect();
                let sigma_of = |component: usize| {
                    used[group_of(component)]
                        * match component {
                            0..3 => ts.position_m[component],
                            3..6 => ts.attitude_rad[component - 3],
                            _ => ts.position_m[component - 6],
                        }
                };
                trajectory_factor = used;
                let lines = strip_adjust::line_corrections(
                    &joint,
                    &sensitivity.labels,
                    free.len(),
                    strip_model,
                    &spans,
                    sigma_of,
                );
                let has_control = model.ties.iter().any(|t| t.control.is_some());
                let has_prior: [bool; PARAM_COUNT] =
                    std::array::from_fn(|i| options.prior_sigma[i].is_some());
                let confounded = strip_adjust::confounded(
                    &joint,
                    &sensitivity.labels,
                    &free,
                    has_control,
                    &has_prior,
                );
                let adjusted = DVector::from_vec(r.clone()) - sensitivity.matrix() * &joint.u;
                let rms = |v: &[f64]| {
                    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
                };
                let before = VtpmProblem {
                    strips,
                    model: model.clone(),
                    whitening: None,
                }
                .residuals(&x0);
                let tests = (0..2)
                    .filter(|&g| first[g].1 > 0.5)
                    .map(|g| SigmaTest {
                        group: GROUP_NAMES[g],
                        statistic: first[g].0,
                        redundancy: first[g].1,
                        quantile_99: chi2_quantile_99(first[g].1),
                        factor: trajectory_factor[g],
                    })
                    .collect();
                let datum = if has_control {
                    "control: the control points fix the common correction of all lines".to_string()
                } else {
                    "minimal constraint: without control the ties see only the lines' corrections \
                     relative to one another; their common part is held at zero by the priors \
                     (each line's correction with the sensor file's sigma), a weighted minimal \
                     constraint"
                        .to_string()
                };
                strip_result = Some(StripAdjustment {
                    model: strip_model,
                    datum,
                    lines,
                    tests,
                    confounded,
                    tie_rms_m: [rms(&before), rms(&r), rms(adjusted.as_slice())],
                });
                break fit;
            };
            // Holds are decided on the unweighted fit; what the data add to a prior, on the
            // weighted one (its σ include the trajectory).
            for i in 0..PARAM_COUNT {
                if geometry.held[i] {
                    solved.observable[i] = false;
                    solved.held_because[i] = geometry.held_because[i].clone();
                }
            }
            solved
        }
    };
    let mut warnings = warnings;
    warnings.extend(held_parameter_warnings(&solved));
    if let Some(sa) = &strip_result {
        warnings.extend(sigma_understated_warnings(sa, options));
    }
    let history = solved
        .history
        .iter()
        .enumerate()
        .map(|(k, (x, m))| IterationRecord {
            iteration: k,
            parameters: *x,
            ties: tie_means(&m.model),
        })
        .collect();
    let ties = tie_reports(strips, &model, &solved.model.model);
    Ok(Calibration {
        history,
        skipped_control: model.skipped_control.clone(),
        trajectory_sigma: options.trajectory_sigma,
        dropped_picks: model.dropped_picks.clone(),
        warnings,
        strip_adjustment: strip_result,
        ..solved.into_calibration(Method::Vtpm, prior, options, ties)
    })
}

/// How much a held parameter's error moves the solved ones, one warning per held parameter (code
/// `held_parameter_moves_others`): a held value is an assumption, and when it is wrong the
/// others absorb it. Lever z held at 0 without control, against 0.2 m true, put 4 mm into the
/// horizontal lever arm of the calibration crate's noise-free survey: with the platform pitched,
/// a lever z error moves the points along track, reversing with the direction as lever x does.
fn held_parameter_warnings<M>(solved: &Solved<M>) -> Vec<Warning> {
    let unit = |p: Param| if p.is_angle() { "deg" } else { "m" };
    Param::ALL
        .iter()
        .filter_map(|&h| {
            let shift = solved.held_shift[h.index()]?;
            // Per 0.1 m of a lever arm, per 0.01° of an angle.
            let step = if h.is_angle() { 0.01f64.to_radians() } else { 0.1 };
            let moves: Vec<String> = Param::ALL
                .iter()
                .filter(|p| !solved.held[p.index()])
                .map(|&p| {
                    let d = shift[p.index()] * step;
                    if p.is_angle() {
                        format!("{} by {:+.5} deg", p.key(), p.to_display(d))
                    } else {
                        format!("{} by {:+.1} mm", p.key(), 1e3 * d)
                    }
                })
                .collect();
            if moves.is_empty() {
                return None;
            }
            Some(Warning::new(
                "held_parameter_moves_others",
                format!(
                    "{} is held at {:.4} {}: each {} {} it is off moves {}; control points (or a [mounting_sigma] prior for it) make the others independent of the held value",
                    h.key(),
                    h.to_display(solved.x[h.index()]),
                    unit(h),
                    if h.is_angle() { "0.01" } else { "0.1" },
                    unit(h),
                    moves.join(", ")
                ),
            ))
        })
        .collect()
}

/// One warning `trajectory_sigma_understated` per trajectory group whose declared σ failed the
/// χ² test (and were scaled by the data; σ scaled without a failed test are not warned of).
fn sigma_understated_warnings(sa: &StripAdjustment, options: &CalibrationOptions) -> Vec<Warning> {
    let Some(ts) = &options.trajectory_sigma else {
        return Vec::new();
    };
    sa.tests
        .iter()
        .filter(|t| t.factor > 1.0 && t.statistic > t.quantile_99)
        .map(|t| {
            let (keys, declared, scaled) = if t.group == "gnss_position" {
                let f = |v: &[f64; 3], k: f64| {
                    format!("{:.3}/{:.3}/{:.3} m", v[0] * k, v[1] * k, v[2] * k)
                };
                (
                    "gnss_north_m, gnss_east_m, gnss_up_m",
                    f(&ts.position_m, 1.0),
                    f(&ts.position_m, t.factor),
                )
            } else {
                let f = |v: &[f64; 3], k: f64| {
                    format!(
                        "{:.4}/{:.4}/{:.4} deg",
                        v[0].to_degrees() * k,
                        v[1].to_degrees() * k,
                        v[2].to_degrees() * k
                    )
                };
                (
                    "roll_deg, pitch_deg, heading_deg",
                    f(&ts.attitude_rad, 1.0),
                    f(&ts.attitude_rad, t.factor),
                )
            };
            Warning::new(
                "trajectory_sigma_understated",
                format!(
                    "the lines' {} corrections exceed what the sensor file's sigma allow (chi-square {:.1} on {:.1} degrees of freedom, 99 % limit {:.1}): their sigma were multiplied by {:.2}, from {declared} to {scaled}; fix [sigma] {keys} in the sensor file (or the navigation processing)",
                    if t.group == "gnss_position" { "GNSS position" } else { "attitude" },
                    t.statistic,
                    t.redundancy,
                    t.quantile_99,
                    t.factor
                ),
            )
        })
        .collect()
}

/// Most re-weightings of the ties' own noise against the trajectory's (see `calibrate_vtpm`).
const MAX_NOISE_PASSES: usize = 8;
/// When the weighted fit's σ0 and the σ_t it was weighted with agree (relative).
const NOISE_AGREEMENT: f64 = 0.02;
/// Most re-solves with the trajectory's σ scaled by the data (strip adjustment).
const MAX_TRAJECTORY_PASSES: usize = 8;
/// When the trajectory σ factor and the data agree (relative).
const TRAJECTORY_AGREEMENT: f64 = 0.03;

/// Removes blunders before the adjustment proper: solve once with every parameter free, then drop
/// the tie with the largest residual (RMS per observed direction) while it exceeds 4 robust σ
/// (1.4826 × the median, at least 1.25 cm, so at least 5 cm), up to a fifth of the ties. A wrong automatic tie (a marking whose centroid
/// jumped between strips, a pick on the wrong roof face) would otherwise inflate σ0 and make every
/// parameter look undetermined.
fn screen_outlier_ties(
    strips: &[Strip],
    model: &mut TieModel,
    x0: [f64; PARAM_COUNT],
    options: &CalibrationOptions,
) {
    let screening = options.holding_nothing();
    let max_drop = model.ties.len() / 3;
    for _ in 0..max_drop {
        let problem = VtpmProblem {
            strips,
            model: model.clone(),
            whitening: None,
        };
        let Ok(solved) =
            solve_with_observability(&problem, x0, model.observations(), &screening, false, None)
        else {
            return;
        };
        let reports = tie_reports(strips, model, &solved.model.model);
        // RMS per observed direction, so roof ties (one direction) and markings (three) compare.
        let norms: Vec<f64> = reports
            .iter()
            .zip(&model.ties)
            .map(|(r, t)| {
                let ss = r.residual_after_m.iter().map(|v| v * v).sum::<f64>();
                (ss / t.directions.len().max(1) as f64).sqrt()
            })
            .collect();
        let mut sorted = norms.clone();
        sorted.sort_by(f64::total_cmp);
        let robust = (lidarqa_model::MAD_TO_SIGMA * sorted[sorted.len() / 2]).max(0.0125);
        let (worst, value) = norms
            .iter()
            .enumerate()
            .fold((0, 0.0), |a, (i, v)| if *v > a.1 { (i, *v) } else { a });
        if value <= 3.0 * robust || model.ties[worst].control.is_some() {
            return;
        }
        model.ties.remove(worst);
    }
}

/// Tie residuals of `ties` (and control points) picked in `strips` as delivered (georeferenced
/// with `prior`), before and after re-georeferencing with `mounting`, with no adjustment: the
/// checkpoint evaluation of Zhang & Jiang (2011) Table 2 (picks made on the raw strips, carried to
/// the corrected ones by rule 2).
///
/// # Errors
/// As [`calibrate_vtpm`] for the ties.
pub fn tie_residuals(
    strips: &[Strip],
    ties: &[Tie],
    control: &[NedControlPoint],
    prior: &Mounting,
    mounting: &Mounting,
    options: &VtpmOptions,
) -> Result<Vec<TieReport>> {
    options.check()?;
    check_strips(strips)?;
    let idx = Indexed::new(strips, options.radius_m.max(0.5));
    let before = build_tie_model(&idx, ties, control, &mounting_to_vector(prior), options)?;
    let mut after = before.clone();
    after.accept(strips, &mounting_to_vector(mounting));
    Ok(tie_reports(strips, &before, &after))
}
