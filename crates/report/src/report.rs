//! [`Report`]: the products found in a directory, and the HTML made from them.

use crate::error::{Error, Result};
use crate::products::*;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Every product a report can show; `None` (or empty) for a product that is absent.
///
/// Build it from parsed structs (the demo does), or let [`Report::from_dir`] read a directory.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Products {
    /// `budget.json`.
    pub budget: Option<Budget>,
    /// `budget_sweep_*.json`, with their file names, sorted by file name.
    pub sweeps: Vec<(String, BudgetSweep)>,
    /// `tpu_summary.json`.
    pub tpu: Option<TpuSummaryDocument>,
    /// `evaluate_before.json`.
    pub evaluate_before: Option<Evaluation>,
    /// `evaluate_after.json`.
    pub evaluate_after: Option<Evaluation>,
    /// `calibration.json`.
    pub calibration: Option<CalibrationDocument>,
    /// `calibration_iterations.json`.
    pub calibration_iterations: Option<CalibrationIterationsDocument>,
    /// `truth.json`.
    pub truth: Option<Truth>,
    /// `overlap_before.json`.
    pub overlap_before: Option<OverlapDocument>,
    /// `overlap_after.json`.
    pub overlap_after: Option<OverlapDocument>,
    /// `overlap_mounting_only.json`: after a mounting-only correction, when `overlap_after.json`
    /// is of a strip-adjusted one.
    pub overlap_mounting_only: Option<OverlapDocument>,
    /// `iho.json`.
    pub iho: Option<Iho>,
    /// `qc.json` (`lidarqa qc`).
    pub qc: Option<lidarqa_products::QcDocument>,
    /// The `warnings` of every product read (SPEC §7), with the file they came from.
    pub warnings: Vec<(String, lidarqa_model::Warning)>,
}

impl Products {
    /// The file names of the products present, in report order.
    pub fn present(&self) -> Vec<String> {
        let mut v = Vec::new();
        let mut add = |present: bool, name: &str| {
            if present {
                v.push(name.to_string());
            }
        };
        add(self.budget.is_some(), BUDGET_FILE);
        for (name, _) in &self.sweeps {
            v.push(name.clone());
        }
        let mut add = |present: bool, name: &str| {
            if present {
                v.push(name.to_string());
            }
        };
        add(self.tpu.is_some(), TPU_SUMMARY_FILE);
        add(self.evaluate_before.is_some(), EVALUATE_BEFORE_FILE);
        add(self.evaluate_after.is_some(), EVALUATE_AFTER_FILE);
        add(self.calibration.is_some(), CALIBRATION_FILE);
        add(
            self.calibration_iterations.is_some(),
            CALIBRATION_ITERATIONS_FILE,
        );
        add(self.truth.is_some(), TRUTH_FILE);
        add(self.overlap_before.is_some(), OVERLAP_BEFORE_FILE);
        add(
            self.overlap_mounting_only.is_some(),
            OVERLAP_MOUNTING_ONLY_FILE,
        );
        add(self.overlap_after.is_some(), OVERLAP_AFTER_FILE);
        add(self.iho.is_some(), IHO_FILE);
        add(self.qc.is_some(), QC_FILE);
        v
    }

    /// No product at all.
    pub fn is_empty(&self) -> bool {
        self.present().is_empty()
    }
}

/// Reads and checks one product file.
///
/// # Errors
/// [`Error::Read`], [`Error::Json`] (serde's message names the field, line and column) or
/// [`Error::Invalid`] (names the key), each naming `path`.
pub fn read_product<T: Product>(path: impl AsRef<Path>) -> Result<T> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| Error::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let de = &mut serde_json::Deserializer::from_str(&text);
    let value: T = serde_path_to_error::deserialize(&mut *de).map_err(|e| Error::Json {
        path: path.to_path_buf(),
        key: e.path().to_string(),
        source: e.into_inner(),
    })?;
    // Trailing characters after the object are an error too.
    de.end().map_err(|source| Error::Json {
        path: path.to_path_buf(),
        key: String::new(),
        source,
    })?;
    value.validate().map_err(|(key, message)| Error::Invalid {
        path: path.to_path_buf(),
        key,
        message,
    })?;
    Ok(value)
}

/// The `warnings` array of a product file (SPEC §7); none when the file has none or they do not
/// parse (the product itself was checked by [`read_product`]).
fn product_warnings(path: &Path) -> Vec<lidarqa_model::Warning> {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|mut v| v.get_mut("warnings").map(serde_json::Value::take))
        .and_then(|w| serde_json::from_value(w).ok())
        .unwrap_or_default()
}

/// A report: the products, where they came from, and what was skipped.
#[derive(Debug)]
pub struct Report {
    pub(crate) products: Products,
    pub(crate) source: Option<PathBuf>,
    pub(crate) generated: String,
    pub(crate) version: String,
    pub(crate) skipped: Vec<Error>,
    /// The product files [`Report::from_dir`] read: [`Report::write`] never writes over one.
    pub(crate) read: Vec<PathBuf>,
}

impl Report {
    /// A report of already-parsed products, dated today (UTC).
    pub fn new(products: Products) -> Report {
        Report {
            products,
            source: None,
            generated: today_utc(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            skipped: Vec::new(),
            read: Vec::new(),
        }
    }

    /// Reads every product present in `dir` (see the crate docs for the file names).
    ///
    /// A product that is missing is simply absent from the report. A product that is present
    /// but malformed (bad JSON, a missing field, an impossible value) does **not** fail the
    /// report: its section is skipped, the error (naming the file and the key) is listed in the
    /// report's *Inputs* box, and it is returned by [`Report::skipped`] so that a caller can
    /// warn or refuse (`lidarqa report --strict`).
    ///
    /// # Errors
    /// [`Error::NotADirectory`], or [`Error::Read`] when the directory cannot be listed.
    pub fn from_dir(dir: impl AsRef<Path>) -> Result<Report> {
        let dir = dir.as_ref();
        if !dir.is_dir() {
            return Err(Error::NotADirectory {
                path: dir.to_path_buf(),
            });
        }
        let mut skipped = Vec::new();
        let mut p = Products::default();
        let mut read = Vec::new();
        fn load<T: Product>(
            dir: &Path,
            name: &str,
            skipped: &mut Vec<Error>,
            read: &mut Vec<PathBuf>,
        ) -> Option<T> {
            let path = dir.join(name);
            if !path.exists() {
                return None;
            }
            read.push(path.clone());
            match read_product::<T>(&path) {
                Ok(v) => Some(v),
                Err(e) => {
                    skipped.push(e);
                    None
                }
            }
        }
        p.budget =
            load::<BudgetDocument>(dir, BUDGET_FILE, &mut skipped, &mut read).map(|d| d.budget);
        let entries = std::fs::read_dir(dir).map_err(|source| Error::Read {
            path: dir.to_path_buf(),
            source,
        })?;
        let mut sweep_names: Vec<String> = entries
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(SWEEP_FILE_PREFIX) && n.ends_with(".json"))
            .collect();
        sweep_names.sort();
        for name in sweep_names {
            if let Some(s) = load::<BudgetSweepDocument>(dir, &name, &mut skipped, &mut read) {
                p.sweeps.push((name, s.sweep));
            }
        }
        p.tpu = load(dir, TPU_SUMMARY_FILE, &mut skipped, &mut read);
        p.evaluate_before =
            load::<EvaluateDocument>(dir, EVALUATE_BEFORE_FILE, &mut skipped, &mut read)
                .and_then(|d| d.targets);
        p.evaluate_after =
            load::<EvaluateDocument>(dir, EVALUATE_AFTER_FILE, &mut skipped, &mut read)
                .and_then(|d| d.targets);
        p.calibration = load(dir, CALIBRATION_FILE, &mut skipped, &mut read);
        p.calibration_iterations = load(dir, CALIBRATION_ITERATIONS_FILE, &mut skipped, &mut read);
        p.truth = load(dir, TRUTH_FILE, &mut skipped, &mut read);
        p.overlap_before = load(dir, OVERLAP_BEFORE_FILE, &mut skipped, &mut read);
        p.overlap_mounting_only = load(dir, OVERLAP_MOUNTING_ONLY_FILE, &mut skipped, &mut read);
        p.overlap_after = load(dir, OVERLAP_AFTER_FILE, &mut skipped, &mut read);
        p.iho = load(dir, IHO_FILE, &mut skipped, &mut read);
        p.qc = load(dir, QC_FILE, &mut skipped, &mut read);
        for name in p.present() {
            let w = product_warnings(&dir.join(&name));
            p.warnings.extend(w.into_iter().map(|w| (name.clone(), w)));
        }
        let mut r = Report::new(p);
        r.source = Some(dir.to_path_buf());
        r.skipped = skipped;
        r.read = read;
        Ok(r)
    }

    /// Sets the date printed in the header (default: today, UTC, `YYYY-MM-DD`); useful for
    /// reproducible output.
    #[must_use]
    pub fn with_generated(mut self, date: impl Into<String>) -> Report {
        self.generated = date.into();
        self
    }

    /// Sets the tool version printed in the header (default: this crate's version, which is
    /// the workspace's).
    #[must_use]
    pub fn with_version(mut self, version: impl Into<String>) -> Report {
        self.version = version.into();
        self
    }

    /// The products.
    pub fn products(&self) -> &Products {
        &self.products
    }

    /// Products that were present but malformed and whose sections were skipped.
    pub fn skipped(&self) -> &[Error] {
        &self.skipped
    }

    /// Writes [`Report::to_html`] to `path` atomically (a temporary file renamed when complete),
    /// never over a product the report was read from.
    ///
    /// # Errors
    /// [`Error::Write`] / [`Error::WriteIo`] naming `path`; lidarqa-io's `OutputIsInput` when
    /// `path` is one of the products read.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let html = self.to_html();
        let mut f = lidarqa_io::AtomicFile::create(path, &self.read)?;
        f.write_all(html.as_bytes())
            .map_err(|source| Error::WriteIo {
                path: path.to_path_buf(),
                source,
            })?;
        f.commit()?;
        Ok(())
    }
}

/// Today's date, UTC, `YYYY-MM-DD` (civil-from-days, proleptic Gregorian).
fn today_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    civil_date((secs / 86_400) as i64)
}

/// `days` since 1970-01-01 → `YYYY-MM-DD` (lidarqa-io's one calendar: [`lidarqa_io::CivilDate`]).
pub(crate) fn civil_date(days: i64) -> String {
    lidarqa_io::CivilDate::from_unix_days(days).to_string()
}

#[cfg(test)]
mod tests {

    /// Every product's `warnings` (SPEC §7) show in a block near the top, with their file.
    #[test]
    fn warnings_of_the_products_are_shown_near_the_top() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join(BUDGET_FILE),
            r#"{"scanner": "linear", "refraction": null,
                "footprint": {"north": 0, "east": 0, "up": -100},
                "geometry": {"scan_angle_deg": 0, "range_m": 100, "height_m": 100},
                "sources": [
                 {"name": "gnss_up", "sigma": 0.1, "unit": "m", "north": 0, "east": 0, "up": 0.1,
                  "horizontal": 0, "vertical": 0.1, "three_d": 0.1}],
                "total": {"north": 0, "east": 0, "up": 0.1, "horizontal": 0, "vertical": 0.1,
                          "three_d": 0.1},
                "warnings": [{"code": "mounting_does_not_fit", "message": "fitted yaw <13.96°>"}]}"#,
        )
        .unwrap();
        let r = Report::from_dir(dir.path()).unwrap();
        assert_eq!(r.products().warnings.len(), 1);
        let html = r.to_html();
        let block = html.find("id=\"sec-warnings\"").expect("a warnings block");
        assert!(block < html.find("id=\"sec-budget\"").unwrap());
        assert!(html.contains("mounting_does_not_fit</code>: fitted yaw &lt;13.96°&gt;"));
        // No warnings, no block.
        std::fs::write(
            dir.path().join(BUDGET_FILE),
            std::fs::read_to_string(dir.path().join(BUDGET_FILE))
                .unwrap()
                .replace(
                    r#"[{"code": "mounting_does_not_fit", "message": "fitted yaw <13.96°>"}]"#,
                    "[]",
                ),
        )
        .unwrap();
        assert!(
            !Report::from_dir(dir.path())
                .unwrap()
                .to_html()
                .contains("sec-warnings")
        );
    }
    use super::*;

    #[test]
    fn civil_dates() {
        assert_eq!(civil_date(0), "1970-01-01");
        assert_eq!(civil_date(19_723), "2024-01-01");
        assert_eq!(civil_date(19_782), "2024-02-29");
    }
}
