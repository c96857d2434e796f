//! Point CSVs: control points, targets and tie picks (SPEC §6, §7).
//!
//! | file | required header | optional |
//! |---|---|---|
//! | control points | `id,x,y,z` | `sigma_h,sigma_v` (1-σ, m), any other column (kept, e.g. `radius_m`) |
//! | targets | `id,x,y,z` | any other column (kept: `n_points`, `radius_m`, `method`, …) |
//! | tie picks | `tie,strip,x,y` | any other column (ignored) |
//!
//! Coordinates are projected metres. Columns may come in any order; names are matched exactly
//! after trimming spaces. Parsing uses the `csv` crate (quoting, CRLF); the checks are
//! lidarqa's, and every error names the file and the one-based line: a missing column, a
//! non-numeric, NaN or infinite value, a negative sigma, a duplicate id. An empty optional cell
//! means "not given"; an empty required cell is an error.

use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use std::collections::HashMap;
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// The reader pair every CSV here has (STYLE: readers come in pairs) over the type's
/// `read_named`: `from_path` (buffered, errors name the file) and `new` (any reader, errors name
/// `<stream>`); `$what` names the file in the docs, `$errors` lists its errors.
macro_rules! reader_pair {
    ($what:literal, $errors:literal) => {
        #[doc = concat!("Reads a ", $what, " CSV.")]
        ///
        /// # Errors
        #[doc = $errors]
        pub fn from_path(path: impl AsRef<Path>) -> Result<Self> {
            let path = path.as_ref();
            let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
            Self::read_named(std::io::BufReader::new(file), path)
        }

        #[doc = concat!("Reads a ", $what, " CSV from a stream; errors name it `<stream>`.")]
        ///
        /// # Errors
        /// As [`from_path`](Self::from_path).
        pub fn new(read: impl Read) -> Result<Self> {
            Self::read_named(read, Path::new("<stream>"))
        }
    };
}

/// One control point.
#[derive(Clone, Debug, PartialEq)]
pub struct ControlRow {
    /// Identifier, unique in the file.
    pub id: String,
    /// Easting, m.
    pub x: f64,
    /// Northing, m.
    pub y: f64,
    /// Height, m.
    pub z: f64,
    /// Horizontal 1-σ, m, if given.
    pub sigma_h_m: Option<f64>,
    /// Vertical 1-σ, m, if given.
    pub sigma_v_m: Option<f64>,
    /// Other columns' cells, aligned with [`PointTable::extra_columns`].
    pub extra: Vec<String>,
    /// One-based line in the file, for later messages.
    pub line: u64,
}

/// One target (the `lidarqa targets` output).
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// Identifier, unique in the file.
    pub id: String,
    /// Easting, m.
    pub x: f64,
    /// Northing, m.
    pub y: f64,
    /// Height, m.
    pub z: f64,
    /// Other columns' cells, aligned with [`PointTable::extra_columns`].
    pub extra: Vec<String>,
    /// One-based line in the file.
    pub line: u64,
}

/// Records of a point CSV with the names of its extra columns.
#[derive(Clone, Debug, PartialEq)]
pub struct PointTable<T> {
    /// The file (or stream name) it was read from.
    pub path: PathBuf,
    /// Names of the columns beyond the known ones, in file order.
    pub extra_columns: Vec<String>,
    /// The records, in file order.
    pub records: Vec<T>,
}

/// A control-points CSV.
pub type ControlPoints = PointTable<ControlRow>;
/// A targets CSV.
pub type Targets = PointTable<Target>;

/// Access to the kept extra cells of a record.
pub trait HasExtra {
    /// The extra cells.
    fn extra(&self) -> &[String];
    /// The record's one-based line.
    fn line(&self) -> u64;
}

impl HasExtra for ControlRow {
    fn extra(&self) -> &[String] {
        &self.extra
    }
    fn line(&self) -> u64 {
        self.line
    }
}

impl HasExtra for Target {
    fn extra(&self) -> &[String] {
        &self.extra
    }
    fn line(&self) -> u64 {
        self.line
    }
}

impl<T: HasExtra> PointTable<T> {
    /// The numeric value of extra column `column` for record `index`: `Ok(None)` when the
    /// column is absent or the cell empty.
    ///
    /// # Errors
    /// [`Error::BadValue`] naming the file, line and column when the cell is not a finite
    /// number.
    pub fn extra_f64(&self, index: usize, column: &str) -> Result<Option<f64>> {
        let Some(j) = self.extra_columns.iter().position(|c| c == column) else {
            return Ok(None);
        };
        let Some(rec) = self.records.get(index) else {
            return Ok(None);
        };
        let cell = rec.extra().get(j).map_or("", |s| s.trim());
        if cell.is_empty() {
            return Ok(None);
        }
        parse_finite(&self.path, rec.line(), column, cell).map(Some)
    }
}

impl ControlPoints {
    reader_pair!(
        "control-points",
        "[`Error::Io`] and the CSV errors listed in the module docs."
    );

    fn read_named(read: impl Read, path: &Path) -> Result<Self> {
        read_points(read, path, &["sigma_h", "sigma_v"], |row| {
            let sigma = |k: usize| -> Result<Option<f64>> {
                let v = row.optional_f64(k)?;
                if let Some(s) = v {
                    if s < 0.0 {
                        return Err(row.bad(k, format!("sigma `{s}` is negative")));
                    }
                }
                Ok(v)
            };
            Ok(ControlRow {
                id: row.id.clone(),
                x: row.xyz[0],
                y: row.xyz[1],
                z: row.xyz[2],
                sigma_h_m: sigma(0)?,
                sigma_v_m: sigma(1)?,
                extra: row.extra.clone(),
                line: row.line,
            })
        })
    }
}

impl Targets {
    reader_pair!(
        "targets",
        "[`Error::Io`] and the CSV errors listed in the module docs."
    );

    fn read_named(read: impl Read, path: &Path) -> Result<Self> {
        read_points(read, path, &[], |row| {
            Ok(Target {
                id: row.id.clone(),
                x: row.xyz[0],
                y: row.xyz[1],
                z: row.xyz[2],
                extra: row.extra.clone(),
                line: row.line,
            })
        })
    }

    /// Writes the targets as CSV (`id,x,y,z` then the extra columns), coordinates with 4
    /// decimals (0.1 mm), to any writer.
    ///
    /// # Errors
    /// [`Error::Io`] naming `self.path`.
    pub fn write_to(&self, write: impl Write) -> Result<()> {
        let mut w = ::csv::Writer::from_writer(write);
        let io = |e: ::csv::Error| Error::io(&self.path, std::io::Error::other(e));
        let mut header = vec!["id".to_string(), "x".into(), "y".into(), "z".into()];
        header.extend(self.extra_columns.iter().cloned());
        w.write_record(&header).map_err(io)?;
        for t in &self.records {
            let mut row = vec![
                t.id.clone(),
                format!("{:.4}", t.x),
                format!("{:.4}", t.y),
                format!("{:.4}", t.z),
            ];
            row.extend(t.extra.iter().cloned());
            w.write_record(&row).map_err(io)?;
        }
        w.flush().map_err(|e| Error::io(&self.path, e))
    }

    /// Writes the targets atomically to `path`, refusing to overwrite any of `inputs`.
    ///
    /// # Errors
    /// [`Error::OutputIsInput`], [`Error::Io`].
    pub fn write_path<P: AsRef<Path>>(&self, path: impl AsRef<Path>, inputs: &[P]) -> Result<()> {
        let path = path.as_ref();
        let file = AtomicFile::create(path, inputs)?;
        let mut buffered = BufWriter::new(file);
        self.write_to(&mut buffered)?;
        let file = buffered
            .into_inner()
            .map_err(|e| Error::io(path, e.into_error()))?;
        file.commit()
    }
}

/// One pick of a tie point in one strip.
#[derive(Clone, Debug, PartialEq)]
pub struct TiePick {
    /// Tie identifier: picks with the same `tie` show the same feature.
    pub tie: String,
    /// Strip: the LAS point source id or the file's stem, as written in the CSV.
    pub strip: String,
    /// Easting, m.
    pub x: f64,
    /// Northing, m.
    pub y: f64,
    /// One-based line in the file.
    pub line: u64,
}

/// A tie picks CSV (`tie,strip,x,y`). Every tie has picks in at least two strips and each
/// (tie, strip) pair appears once.
#[derive(Clone, Debug, PartialEq)]
pub struct TiePicks {
    /// The file it was read from.
    pub path: PathBuf,
    /// The picks, in file order.
    pub picks: Vec<TiePick>,
}

impl TiePicks {
    reader_pair!(
        "tie picks",
        "[`Error::Io`], the CSV errors of the module docs, [`Error::DuplicateKey`] for a repeated (tie, strip) pair, [`Error::LonelyTie`] for a tie picked in one strip only."
    );

    fn read_named(read: impl Read, path: &Path) -> Result<Self> {
        let mut rows = Rows::new(read, path, &["tie", "strip", "x", "y"], &[])?;
        let mut picks = Vec::new();
        let mut seen: HashMap<(String, String), u64> = HashMap::new();
        while let Some(row) = rows.next_row()? {
            let line = row.line;
            let tie = row.required_str(0)?;
            let strip = row.required_str(1)?;
            let x = row.required_f64(2)?;
            let y = row.required_f64(3)?;
            if let Some(&first_line) = seen.get(&(tie.clone(), strip.clone())) {
                return Err(Error::DuplicateKey {
                    path: path.to_path_buf(),
                    line,
                    first_line,
                    what: "tie/strip pair",
                    key: format!("{tie}/{strip}"),
                });
            }
            seen.insert((tie.clone(), strip.clone()), line);
            picks.push(TiePick {
                tie,
                strip,
                x,
                y,
                line,
            });
        }
        let mut count: HashMap<&str, usize> = HashMap::new();
        for p in &picks {
            *count.entry(p.tie.as_str()).or_default() += 1;
        }
        if let Some(p) = picks.iter().find(|p| count[p.tie.as_str()] < 2) {
            return Err(Error::LonelyTie {
                path: path.to_path_buf(),
                line: p.line,
                tie: p.tie.clone(),
            });
        }
        Ok(TiePicks {
            path: path.to_path_buf(),
            picks,
        })
    }
}

fn parse_finite(path: &Path, line: u64, column: &str, cell: &str) -> Result<f64> {
    let bad = |message: String| Error::BadValue {
        path: path.to_path_buf(),
        line,
        column: column.to_string(),
        message,
    };
    let v: f64 = cell
        .parse()
        .map_err(|_| bad(format!("`{cell}` is not a number")))?;
    if !v.is_finite() {
        return Err(bad(format!("`{cell}` is not a finite number")));
    }
    Ok(v)
}

/// A CSV reader that maps named columns to indices and reports lines.
struct Rows<R: Read> {
    reader: ::csv::Reader<R>,
    path: PathBuf,
    required: Vec<usize>,
    optional: Vec<Option<usize>>,
    optional_names: Vec<String>,
    required_names: Vec<String>,
    extra: Vec<usize>,
    extra_names: Vec<String>,
    record: ::csv::StringRecord,
}

/// One parsed row.
struct Row<'a> {
    path: &'a Path,
    line: u64,
    cells: Vec<&'a str>,
    required_names: &'a [String],
    optional_names: &'a [String],
    required: &'a [usize],
    optional: &'a [Option<usize>],
}

impl Row<'_> {
    fn bad_named(&self, column: &str, message: String) -> Error {
        Error::BadValue {
            path: self.path.to_path_buf(),
            line: self.line,
            column: column.to_string(),
            message,
        }
    }

    /// An error about optional column `k`.
    fn bad_opt(&self, k: usize, message: String) -> Error {
        self.bad_named(&self.optional_names[k], message)
    }

    fn required_str(&self, k: usize) -> Result<String> {
        let cell = self.cells[self.required[k]].trim();
        if cell.is_empty() {
            return Err(self.bad_named(&self.required_names[k], "empty cell".into()));
        }
        Ok(cell.to_string())
    }

    fn required_f64(&self, k: usize) -> Result<f64> {
        let cell = self.required_str(k)?;
        parse_finite(self.path, self.line, &self.required_names[k], &cell)
    }

    fn optional_f64(&self, k: usize) -> Result<Option<f64>> {
        let Some(i) = self.optional[k] else {
            return Ok(None);
        };
        let cell = self.cells[i].trim();
        if cell.is_empty() {
            return Ok(None);
        }
        parse_finite(self.path, self.line, &self.optional_names[k], cell).map(Some)
    }
}

impl<R: Read> Rows<R> {
    fn new(read: R, path: &Path, required: &[&str], optional: &[&str]) -> Result<Self> {
        let mut reader = ::csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(false)
            .trim(::csv::Trim::Headers)
            .from_reader(read);
        let csv_err = |e: ::csv::Error, line: u64| Error::Csv {
            path: path.to_path_buf(),
            line: e.position().map_or(line, |p| p.line()),
            message: e.to_string(),
        };
        let headers = reader.headers().map_err(|e| csv_err(e, 1))?.clone();
        let names: Vec<String> = headers.iter().map(|h| h.trim().to_string()).collect();
        let find = |n: &str| names.iter().position(|h| h == n);
        let mut req = Vec::new();
        for &n in required {
            match find(n) {
                Some(i) => req.push(i),
                None => {
                    return Err(Error::MissingColumn {
                        path: path.to_path_buf(),
                        line: 1,
                        column: n.to_string(),
                    });
                }
            }
        }
        let opt: Vec<Option<usize>> = optional.iter().map(|n| find(n)).collect();
        let extra: Vec<usize> = (0..names.len())
            .filter(|i| !req.contains(i) && !opt.contains(&Some(*i)))
            .collect();
        // A repeated column name would make "the" value ambiguous.
        for (i, n) in names.iter().enumerate() {
            if let Some(j) = names[..i].iter().position(|m| m == n) {
                return Err(Error::DuplicateKey {
                    path: path.to_path_buf(),
                    line: 1,
                    first_line: 1,
                    what: "column",
                    key: format!("{n} (columns {} and {})", j + 1, i + 1),
                });
            }
        }
        Ok(Rows {
            reader,
            path: path.to_path_buf(),
            extra_names: extra.iter().map(|&i| names[i].clone()).collect(),
            required: req,
            optional: opt,
            optional_names: optional.iter().map(|s| s.to_string()).collect(),
            required_names: required.iter().map(|s| s.to_string()).collect(),
            extra,
            record: ::csv::StringRecord::new(),
        })
    }

    fn next_row(&mut self) -> Result<Option<Row<'_>>> {
        let more = self
            .reader
            .read_record(&mut self.record)
            .map_err(|e| Error::Csv {
                path: self.path.clone(),
                line: e.position().map_or(0, |p| p.line()),
                message: e.to_string(),
            })?;
        if !more {
            return Ok(None);
        }
        let line = self.record.position().map_or(0, |p| p.line());
        Ok(Some(Row {
            path: &self.path,
            line,
            cells: self.record.iter().collect(),
            required_names: &self.required_names,
            optional_names: &self.optional_names,
            required: &self.required,
            optional: &self.optional,
        }))
    }
}

/// Fields common to control points and targets, handed to the record builder.
struct PointRow<'a> {
    row: Row<'a>,
    id: String,
    xyz: [f64; 3],
    extra: Vec<String>,
    line: u64,
}

impl PointRow<'_> {
    fn optional_f64(&self, k: usize) -> Result<Option<f64>> {
        self.row.optional_f64(k)
    }
    fn bad(&self, k: usize, message: String) -> Error {
        self.row.bad_opt(k, message)
    }
}

fn read_points<T>(
    read: impl Read,
    path: &Path,
    optional: &[&str],
    build: impl Fn(&PointRow<'_>) -> Result<T>,
) -> Result<PointTable<T>> {
    let mut rows = Rows::new(read, path, &["id", "x", "y", "z"], optional)?;
    let extra_idx = rows.extra.clone();
    let extra_columns = rows.extra_names.clone();
    let mut records = Vec::new();
    let mut seen: HashMap<String, u64> = HashMap::new();
    while let Some(row) = rows.next_row()? {
        let id = row.required_str(0)?;
        let line = row.line;
        if let Some(&first_line) = seen.get(&id) {
            return Err(Error::DuplicateKey {
                path: path.to_path_buf(),
                line,
                first_line,
                what: "id",
                key: id,
            });
        }
        seen.insert(id.clone(), line);
        let xyz = [
            row.required_f64(1)?,
            row.required_f64(2)?,
            row.required_f64(3)?,
        ];
        let extra = extra_idx
            .iter()
            .map(|&i| row.cells[i].to_string())
            .collect();
        let pr = PointRow {
            row,
            id,
            xyz,
            extra,
            line,
        };
        records.push(build(&pr)?);
    }
    Ok(PointTable {
        path: path.to_path_buf(),
        extra_columns,
        records,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn control(text: &str) -> Result<ControlPoints> {
        ControlPoints::read_named(text.as_bytes(), Path::new("control.csv"))
    }

    #[test]
    fn control_with_sigmas_and_extra_columns_in_any_order() {
        let c = control(
            "x, id ,y,z,radius_m,sigma_v,note\n\
             500010.5,T1,4982950.25,101.5,0.8,0.02,on roof\n\
             500020,T2,4982960,102,,,\n",
        )
        .unwrap();
        assert_eq!(c.extra_columns, vec!["radius_m", "note"]);
        let t1 = &c.records[0];
        assert_eq!(
            (t1.id.as_str(), t1.x, t1.y, t1.z),
            ("T1", 500010.5, 4982950.25, 101.5)
        );
        assert_eq!((t1.sigma_h_m, t1.sigma_v_m), (None, Some(0.02)));
        assert_eq!(t1.line, 2);
        assert_eq!(c.extra_f64(0, "radius_m").unwrap(), Some(0.8));
        assert_eq!(c.extra_f64(1, "radius_m").unwrap(), None);
        assert_eq!(c.extra_f64(0, "absent").unwrap(), None);
        let e = c.extra_f64(0, "note").unwrap_err().to_string();
        assert_eq!(
            e,
            "control.csv: line 2: column `note`: `on roof` is not a number"
        );
        assert_eq!(c.records[1].line, 3);
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = control("id,x,y\nA,1,2\n").unwrap_err().to_string();
        assert_eq!(e, "control.csv: line 1: missing column `z`");
        let e = control("id,x,y,z\nA,1,2,3\nB,1,two,3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "control.csv: line 3: column `y`: `two` is not a number");
        let e = control("id,x,y,z\nA,1,2,NaN\n").unwrap_err().to_string();
        assert_eq!(
            e,
            "control.csv: line 2: column `z`: `NaN` is not a finite number"
        );
        let e = control("id,x,y,z\nA,1,2,3\nB,1,2,3\nA,4,5,6\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "control.csv: line 4: duplicate id `A` (first on line 2)");
        let e = control("id,x,y,z,sigma_h\nA,1,2,3,-0.1\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "control.csv: line 2: column `sigma_h`: sigma `-0.1` is negative"
        );
        let e = control("id,x,y,z\nA,1,2,3\nB,1,2\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("control.csv: line 3: "), "{e}");
        let e = control("id,x,y,z\n,1,2,3\n").unwrap_err().to_string();
        assert_eq!(e, "control.csv: line 2: column `id`: empty cell");
        let e = control("id,x,x,y,z\nA,1,1,2,3\n").unwrap_err().to_string();
        assert!(e.contains("duplicate column"), "{e}");
    }

    #[test]
    fn targets_round_trip_through_writer() {
        let t = Targets::read_named(
            "id,x,y,z,n_points,method\nT1,1.00005,2,3,57,centroid\n".as_bytes(),
            Path::new("t.csv"),
        )
        .unwrap();
        let mut out = Vec::new();
        t.write_to(&mut out).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "id,x,y,z,n_points,method\nT1,1.0001,2.0000,3.0000,57,centroid\n"
        );
    }

    #[test]
    fn tie_picks_checks() {
        let t = TiePicks::read_named(
            "tie,strip,x,y\nt1,1,10,20\nt1,2,10.1,20.2\n".as_bytes(),
            Path::new("ties.csv"),
        )
        .unwrap();
        assert_eq!(t.picks.len(), 2);
        assert_eq!(t.picks[1].strip, "2");
        assert_eq!(t.picks[1].x, 10.1);
        let e = TiePicks::read_named(
            "tie,strip,x,y\nt1,1,10,20\nt1,2,10,20\nt2,1,0,0\n".as_bytes(),
            Path::new("ties.csv"),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "ties.csv: line 4: tie `t2` is picked in only one strip; a tie needs two or more"
        );
        let e = TiePicks::read_named(
            "tie,strip,x,y\nt1,1,10,20\nt1,1,10,20\n".as_bytes(),
            Path::new("ties.csv"),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "ties.csv: line 3: duplicate tie/strip pair `t1/1` (first on line 2)"
        );
        let e = TiePicks::read_named("tie,x,y\n".as_bytes(), Path::new("ties.csv"))
            .unwrap_err()
            .to_string();
        assert_eq!(e, "ties.csv: line 1: missing column `strip`");
    }
}
