//! IHO S-44 (Edition 6.0.0, 2020, Table 1) survey orders and the 95 % uncertainties of a sounding.
//!
//! | order | THU (95 %) | TVU (95 %): a, b |
//! |---|---|---|
//! | Exclusive | 1 m | 0.15 m, 0.0075 |
//! | Special | 2 m | 0.25 m, 0.0075 |
//! | 1a | 5 m + 5 % of depth | 0.5 m, 0.013 |
//! | 1b | 5 m + 5 % of depth | 0.5 m, 0.013 |
//! | 2 | 20 m + 10 % of depth | 1.0 m, 0.023 |
//!
//! with the maximum allowable TVU `√(a² + (b·d)²)` at depth `d`. Orders 1a and 1b share their
//! THU and TVU; they differ in feature detection and coverage, which are not a property of one
//! sounding, so a sounding that meets their limits is reported as meeting both.
//!
//! **95 % horizontal uncertainty.** IHO asks for THU at 95 % confidence. For a sounding with the
//! horizontal covariance `C` (eigenvalues λ₁ ≥ λ₂) that is the radius `r` with
//! `P(λ₁ Z₁² + λ₂ Z₂² ≤ r²) = 0.95` ([`thu_95_m`], exact to 1e-4 relative here). For a circular
//! error (λ₁ = λ₂ = σ²) it is `2.4477 σ = 1.7308 σ_H` (σ_H = √(σ_N² + σ_E²)), which is cBLUE's
//! `total_thu` (SPEC §7); for a fully elongated one (λ₂ = 0) it is `1.96 σ_H`. A conic scanner's
//! horizontal error ellipse is elongated (the water-time and slope terms lie along the beam), so
//! lidarqa's IHO comparison uses the exact radius of each sounding's own ellipse, never smaller
//! than the `total_thu` field and up to 13 % larger. TVU at 95 % is `1.96 σ_V`.

use nalgebra::Matrix2;
use serde::Serialize;

/// Factor of σ_V for the 95 % vertical uncertainty (normal distribution): model's
/// [`NORMAL_95_FACTOR`](lidarqa_model::NORMAL_95_FACTOR).
pub const TVU_95_FACTOR: f64 = lidarqa_model::NORMAL_95_FACTOR;
/// 95 % radius of a circular bivariate normal in units of its per-axis σ: `√(−2 ln 0.05)`.
pub const THU_95_CIRCULAR_PER_AXIS: f64 = 2.447_746_830_680_816;
/// cBLUE's `total_thu` factor of σ_H: the circular 95 % radius `2.4477 / √2` (SPEC §7), model's
/// [`CIRCULAR_95_FACTOR`](lidarqa_model::CIRCULAR_95_FACTOR).
pub const THU_95_CBLUE: f64 = lidarqa_model::CIRCULAR_95_FACTOR;

/// An S-44 order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum IhoOrder {
    /// Exclusive Order (harbours and critical under-keel areas).
    #[serde(rename = "exclusive")]
    Exclusive,
    /// Special Order.
    #[serde(rename = "special")]
    Special,
    /// Order 1a.
    #[serde(rename = "1a")]
    Order1a,
    /// Order 1b.
    #[serde(rename = "1b")]
    Order1b,
    /// Order 2.
    #[serde(rename = "2")]
    Order2,
}

/// The limits of one order (S-44 Ed. 6 Table 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IhoLimits {
    /// Constant part of the THU, m.
    pub thu_m: f64,
    /// Depth-proportional part of the THU (0.05 = 5 % of depth).
    pub thu_depth_fraction: f64,
    /// TVU constant `a`, m.
    pub tvu_a_m: f64,
    /// TVU depth factor `b`.
    pub tvu_b: f64,
}

impl IhoOrder {
    /// Every order, most stringent first.
    pub const ALL: [IhoOrder; 5] = [
        IhoOrder::Exclusive,
        IhoOrder::Special,
        IhoOrder::Order1a,
        IhoOrder::Order1b,
        IhoOrder::Order2,
    ];

    /// `exclusive`, `special`, `1a`, `1b`, `2`.
    pub fn name(self) -> &'static str {
        match self {
            IhoOrder::Exclusive => "exclusive",
            IhoOrder::Special => "special",
            IhoOrder::Order1a => "1a",
            IhoOrder::Order1b => "1b",
            IhoOrder::Order2 => "2",
        }
    }

    /// The order's limits.
    pub fn limits(self) -> IhoLimits {
        let (thu_m, thu_depth_fraction, tvu_a_m, tvu_b) = match self {
            IhoOrder::Exclusive => (1.0, 0.0, 0.15, 0.0075),
            IhoOrder::Special => (2.0, 0.0, 0.25, 0.0075),
            IhoOrder::Order1a | IhoOrder::Order1b => (5.0, 0.05, 0.5, 0.013),
            IhoOrder::Order2 => (20.0, 0.10, 1.0, 0.023),
        };
        IhoLimits {
            thu_m,
            thu_depth_fraction,
            tvu_a_m,
            tvu_b,
        }
    }

    /// Maximum allowable THU (95 %) at depth `depth_m`, m: `c + f·d`.
    pub fn max_thu_m(self, depth_m: f64) -> f64 {
        let l = self.limits();
        l.thu_m + l.thu_depth_fraction * depth_m
    }

    /// Maximum allowable TVU (95 %) at depth `depth_m`, m: `√(a² + (b·d)²)`.
    pub fn max_tvu_m(self, depth_m: f64) -> f64 {
        let l = self.limits();
        // Metres: the plain root cannot overflow (no `hypot`, which is slow, for every order
        // of every sounding).
        let b_d = l.tvu_b * depth_m;
        (l.tvu_a_m * l.tvu_a_m + b_d * b_d).sqrt()
    }

    /// Whether a sounding at `depth_m` with these 95 % uncertainties meets the order
    /// (`(THU met, TVU met)`).
    pub fn check(self, depth_m: f64, thu_95_m: f64, tvu_95_m: f64) -> (bool, bool) {
        (
            thu_95_m <= self.max_thu_m(depth_m),
            tvu_95_m <= self.max_tvu_m(depth_m),
        )
    }

    /// The most stringent order whose THU and TVU the sounding meets, if any.
    pub fn best(depth_m: f64, thu_95_m: f64, tvu_95_m: f64) -> Option<IhoOrder> {
        IhoOrder::ALL.into_iter().find(|o| {
            let (h, v) = o.check(depth_m, thu_95_m, tvu_95_m);
            h && v
        })
    }
}

#[cfg(test)]
/// Standard normal CDF from a rational erfc approximation (W. J. Cody's erfc to ~1e-7 via
/// Numerical Recipes' `erfcc`, relative error < 1.2e-7).
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let erfc = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

#[cfg(test)]
/// `P(Z₁² + k Z₂² ≤ s²)` for independent standard normals, 0 ≤ k ≤ 1: Simpson's rule over
/// `z₁ = s sin θ`, which removes the square-root end points.
fn prob_within(s: f64, k: f64) -> f64 {
    if k <= 0.0 {
        return 2.0 * normal_cdf(s) - 1.0;
    }
    let n = 400; // even
    let h = std::f64::consts::PI / n as f64;
    let f = |theta: f64| {
        let (st, ct) = theta.sin_cos();
        let z1 = s * st;
        let w = (-0.5 * z1 * z1).exp() / (2.0 * std::f64::consts::PI).sqrt() * s * ct;
        w * (2.0 * normal_cdf(s * ct / k.sqrt()) - 1.0)
    };
    let (a, b) = (-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2);
    let mut sum = f(a) + f(b);
    for i in 1..n {
        let x = a + i as f64 * h;
        sum += f(x) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

/// The 95 % radius in units of √λ₁ for the eigenvalue ratio `k = λ₂/λ₁`: the root of
/// `P(s) − 0.95` on [1.9, 2.5] by false position with the Illinois modification (superlinear,
/// about ten integrals instead of bisection's sixty). The source of [`FACTOR_TABLE`].
#[cfg(test)]
fn radius_factor(k: f64) -> f64 {
    let g = |s: f64| prob_within(s, k) - 0.95;
    let (mut a, mut b) = (1.9, 2.5);
    let (mut fa, mut fb) = (g(a), g(b));
    // The side that moved last: halving the other end's value keeps both ends converging.
    let mut last = 0i8;
    let mut c = 0.5 * (a + b);
    for _ in 0..100 {
        c = (a * fb - b * fa) / (fb - fa);
        let fc = g(c);
        if fc.abs() < 1e-15 || b - a < 1e-13 {
            break;
        }
        if fc < 0.0 {
            (a, fa) = (c, fc);
            if last == -1 {
                fb *= 0.5;
            }
            last = -1;
        } else {
            (b, fb) = (c, fc);
            if last == 1 {
                fa *= 0.5;
            }
            last = 1;
        }
    }
    c
}

const TABLE_STEPS: usize = 200;

/// The factor on a grid of `√k` (the factor is smooth in √k): `FACTOR_TABLE[i]` is
/// `radius_factor((i / 200)²)`, computed once and written here (a test recomputes every entry
/// and asserts equality), so that no run spends its first sounding on 201 root searches.
#[rustfmt::skip]
const FACTOR_TABLE: [f64; TABLE_STEPS + 1] = [
    1.9599639471668915, 1.9599643201882222, 1.9599842676785133, 1.9600206098070694,
    1.9600660155026302, 1.9601234820848583, 1.9601936974463878, 1.9602767068381717,
    1.9603725248677641, 1.96048116785706, 1.9606026543357864, 1.9607370050554702,
    1.9608842430030593, 1.9610443934164163, 1.9612174838015293, 1.9614035439513604,
    1.961602605966315, 1.9618147042763232, 1.962039875664854, 1.962278159294428,
    1.9625295967340968, 1.9627942319887786, 1.9630721115304788, 1.9633632843315076,
    1.963667801899749, 1.9639857183160505, 1.964317090273767, 1.9646619771205864,
    1.9650204409027752, 1.9653925464117188, 1.9657783612331765, 1.9661779557990289,
    1.9665914034418959, 1.9670187804526376, 1.9674601661407494, 1.9679156428980582,
    1.9683852962656165, 1.9688692150042313, 1.9693674911683792, 1.969880220184233,
    1.9704075009315736, 1.9709494358300863, 1.9715061309300832, 1.972077696008034,
    1.972664244667256, 1.9732658944439536, 1.9738827669188796, 1.974514987835437,
    1.9751626872238914, 1.9758259995330913, 1.9765050637692767, 1.977200023643334,
    1.9779110277266088, 1.9786382296163496, 1.9793817881114546, 1.980141867399564,
    1.9809186372565848, 1.9817122732599457, 1.9825229570171787, 1.9833508764115355,
    1.984196225866607, 1.9850592066325257, 1.9859400270961791, 1.9868389031183546,
    1.9877560584012048, 1.9886917248890006, 1.9896461432056973, 1.990619563132212,
    1.991612244126476, 1.9926244558878585, 1.9936564789676898, 1.9947086054254817,
    1.995781139529594, 1.9968743984994015, 1.9979887132833962, 1.9991244293670027,
    2.0002819076001987, 2.0014615250343533, 2.0026636757544676, 2.00388877169261,
    2.00513724340509, 2.0064095407962808, 2.0077061337702546, 2.009027512791226,
    2.0103741893341107, 2.011746696206802, 2.013145587726963, 2.0145714397378813,
    2.0160248494491957, 2.0175064350916774, 2.019016835376839, 2.0205567087557688,
    2.0221267324743617, 2.0237276014253243, 2.0253600268006604, 2.0270247345512953,
    2.0287224636637453, 2.030453964266501, 2.0322199955813818, 2.0340213237376967,
    2.035858719468439, 2.0377329557101582, 2.0396448051289022, 2.0415950375953917,
    2.043584417633375, 2.045613701865062, 2.0476836364768864, 2.0497949547285,
    2.0519483745268863, 2.054144596085785, 2.0563842996895594, 2.0586681435782808,
    2.060996761969408, 2.0633707632289227, 2.065790728202809, 2.0682572087174846,
    2.0707707262556516, 2.0733317708118504, 2.0759407999296506, 2.0785982379209647,
    2.0813044752656857, 2.0840598681879143, 2.0868647384042944, 2.089719373037802,
    2.0926240246894174, 2.0955789116592807, 2.0985842183078383, 2.1016400955469456,
    2.1047466614504544, 2.1079040019734796, 2.111112171769215, 2.114371195092551,
    2.117681066779364, 2.1210417532908714, 2.1244531938128834, 2.127915301399492,
    2.131427964152264, 2.134991046425543, 2.1386043900495246, 2.142267815563347,
    2.145981123450763, 2.1497440953719655, 2.153556495385384, 2.1574180711541135,
    2.161328555132115, 2.165287665726066, 2.1692951084289485, 2.1733505769224015,
    2.177453754145191, 2.1816043133253014, 2.1858019189742874, 2.1900462278421893,
    2.1943368898322446, 2.19867354887449, 2.2030558437580954, 2.2074834089222333,
    2.211955875205699, 2.216472870555523, 2.2210340206952703, 2.2256389497535904,
    2.230287280854071, 2.2349786366671007, 2.239712639925019, 2.2444889139016486,
    2.249307082857324, 2.2541667724507297, 2.259067610118935, 2.264009225426804,
    2.268991250387031, 2.274013319752468, 2.2790750712815973, 2.2841761459789027,
    2.289316188311058, 2.2944948464004744, 2.2997117721972264, 2.304966621630747,
    2.310259054742363, 2.3155887357996727, 2.3209553333942545, 2.326358520523278,
    2.331797974656326, 2.3372733777883337, 2.3427844164795952, 2.3483307818835932,
    2.353912169763741, 2.359528280499526, 2.3651788190831793, 2.3708634951072134,
    2.376582022743912, 2.382334120717093, 2.3881195122669188, 2.393937925108418,
    2.399789091384002, 2.4056727476107747, 2.411588634623021, 2.41753649751023,
    2.423516085551193, 2.429527152144717, 2.435569454736993, 2.4416427547461614,
    2.4477468174846186,
];

/// The 95 % horizontal uncertainty (radius, m) of a horizontal covariance `c` (m², north/east):
/// `r` with `P(|x| ≤ r) = 0.95` for `x ~ N(0, c)`. See the module docs.
///
/// ```
/// use lidarqa_tpu::thu_95_m;
/// use nalgebra::Matrix2;
/// // Circular, σ = 0.1 m per axis: 2.4477 σ = 1.7308 σ_H.
/// assert!((thu_95_m(&Matrix2::new(0.01, 0.0, 0.0, 0.01)) - 0.244_77).abs() < 1e-4);
/// // One axis only: 1.96 σ.
/// assert!((thu_95_m(&Matrix2::new(0.01, 0.0, 0.0, 0.0)) - 0.196).abs() < 1e-4);
/// ```
pub fn thu_95_m(c: &Matrix2<f64>) -> f64 {
    let (a, b, d) = (c[(0, 0)], 0.5 * (c[(0, 1)] + c[(1, 0)]), c[(1, 1)]);
    let mean = 0.5 * (a + d);
    let half = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let (l1, l2) = ((mean + half).max(0.0), (mean - half).max(0.0));
    if l1 <= 0.0 {
        return 0.0;
    }
    let q = (l2 / l1).sqrt().clamp(0.0, 1.0) * TABLE_STEPS as f64;
    // q ≥ 0: truncation is the floor (and NaN gives 0 either way), without a libm call.
    let i = (q as usize).min(TABLE_STEPS - 1);
    let t = &FACTOR_TABLE;
    let f = t[i] + (q - i as f64) * (t[i + 1] - t[i]);
    f * l1.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_limits() {
        // Special order at 20 m: √(0.25² + (0.0075·20)²) = √(0.0625 + 0.0225) = 0.29155 m.
        assert!((IhoOrder::Special.max_tvu_m(20.0) - 0.291_547_6).abs() < 1e-6);
        // Exclusive at 10 m: √(0.15² + 0.075²) = 0.16771 m; THU 1 m at any depth.
        assert!((IhoOrder::Exclusive.max_tvu_m(10.0) - 0.167_705_1).abs() < 1e-6);
        assert_eq!(IhoOrder::Exclusive.max_thu_m(40.0), 1.0);
        // Order 1a / 1b at 30 m: TVU √(0.5² + 0.39²) = 0.63411 m, THU 5 + 1.5 = 6.5 m.
        assert!((IhoOrder::Order1a.max_tvu_m(30.0) - 0.634_113_5).abs() < 1e-6);
        assert_eq!(IhoOrder::Order1b.max_thu_m(30.0), 6.5);
        // Order 2 at 50 m: TVU √(1 + 1.15²) = 1.52398 m, THU 20 + 5 = 25 m.
        assert!((IhoOrder::Order2.max_tvu_m(50.0) - 1.523_975_1).abs() < 1e-6);
        assert_eq!(IhoOrder::Order2.max_thu_m(50.0), 25.0);
        // At 0 m the TVU limit is a.
        assert_eq!(IhoOrder::Order2.max_tvu_m(0.0), 1.0);
    }

    #[test]
    fn best_order() {
        // 20 m: TVU 0.29 m just within Special, THU 0.3 m within Exclusive's 1 m but the TVU
        // misses Exclusive's 0.2121 m.
        assert_eq!(IhoOrder::best(20.0, 0.3, 0.29), Some(IhoOrder::Special));
        assert_eq!(IhoOrder::best(20.0, 0.3, 0.20), Some(IhoOrder::Exclusive));
        assert_eq!(IhoOrder::best(20.0, 3.0, 0.29), Some(IhoOrder::Order1a));
        assert_eq!(IhoOrder::best(20.0, 3.0, 0.7), Some(IhoOrder::Order2));
        assert_eq!(IhoOrder::best(20.0, 30.0, 0.29), None);
    }

    #[test]
    fn the_written_table_is_the_root_search() {
        for (i, v) in FACTOR_TABLE.iter().enumerate() {
            let q = i as f64 / TABLE_STEPS as f64;
            assert_eq!(*v, radius_factor(q * q), "entry {i}");
        }
    }

    #[test]
    fn radius_factors_match_closed_forms() {
        // Circular: √(−2 ln 0.05) per axis.
        assert!((radius_factor(1.0) - THU_95_CIRCULAR_PER_AXIS).abs() < 1e-5);
        assert!((THU_95_CIRCULAR_PER_AXIS / 2f64.sqrt() - THU_95_CBLUE).abs() < 1e-4);
        // Degenerate: 1.959964.
        assert!((radius_factor(0.0) - 1.959_964).abs() < 1e-5);
        // The root finder lands on the root (P's slope there is ~0.1 per unit s).
        for k in [0.0, 1e-4, 0.003, 0.07, 0.31, 0.77, 1.0] {
            let r = radius_factor(k);
            assert!((prob_within(r, k) - 0.95).abs() < 1e-13, "{k}: {r}");
        }
        // Interpolated table against direct evaluation at awkward ratios.
        for k in [0.003, 0.07, 0.31, 0.77] {
            let c = Matrix2::new(1.0, 0.0, 0.0, k);
            assert!(
                (thu_95_m(&c) / radius_factor(k) - 1.0).abs() < 1e-4,
                "{k}: {} vs {}",
                thu_95_m(&c),
                radius_factor(k)
            );
        }
        // Rotation does not matter.
        let (s, co) = 0.6f64.sin_cos();
        let r = Matrix2::new(co, -s, s, co);
        let c = Matrix2::new(0.04, 0.0, 0.0, 0.01);
        assert!((thu_95_m(&(r * c * r.transpose())) - thu_95_m(&c)).abs() < 1e-12);
    }

    #[test]
    fn monte_carlo_confirms_the_elliptical_radius() {
        use rand::{Rng, SeedableRng};
        use rand_chacha::ChaCha8Rng;
        use rand_distr::StandardNormal;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (sx, sy) = (0.3, 0.1);
        let r = thu_95_m(&Matrix2::new(sx * sx, 0.0, 0.0, sy * sy));
        let n = 200_000;
        let inside = (0..n)
            .filter(|_| {
                let x: f64 = rng.sample::<f64, _>(StandardNormal) * sx;
                let y: f64 = rng.sample::<f64, _>(StandardNormal) * sy;
                x.hypot(y) <= r
            })
            .count();
        let p = inside as f64 / n as f64;
        // Binomial σ at 0.95 over 2e5: 0.0005.
        assert!((p - 0.95).abs() < 0.002, "{p}");
    }
}
