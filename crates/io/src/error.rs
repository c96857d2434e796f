//! The one error type of lidarqa-io.
//!
//! Every variant about a file carries its path, and the record, line or key at fault when there
//! is one, so that the CLI can print a single line a user can act on (SPEC §6). The few variants
//! about a bare value (an EPSG code, a date, a GPS week) carry that value; the functions that take
//! such a value from a file wrap it in a path-carrying variant instead.

use std::path::PathBuf;

/// Everything that can go wrong while reading or writing a lidarqa file.
///
/// Messages are lowercase with no final period; `{path}` is printed as given by the caller.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An operating-system I/O error on a file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },

    /// The `las` crate rejected a LAS/LAZ file, a header or a point.
    #[error("{}: {source}", path.display())]
    Las {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// The underlying error.
        source: las::Error,
    },

    /// The `las` crate rejected one point record.
    #[error("{}: point {index}: {source}", path.display())]
    LasPoint {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Zero-based index of the point in the file.
        index: u64,
        /// The underlying error.
        source: las::Error,
    },

    /// A LAS/LAZ file's content breaks a rule of the format or of lidarqa (extra-bytes VLR,
    /// point record length, …).
    #[error("{}: {message}", path.display())]
    InvalidLas {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// What is wrong, lowercase.
        message: String,
    },

    /// A point handed to the LAS writer does not fit the output's point format or dimensions.
    #[error("{}: point {index}: {message}", path.display())]
    PointMismatch {
        /// The output file.
        path: PathBuf,
        /// Zero-based index of the point in the output.
        index: u64,
        /// What does not match.
        message: String,
    },

    /// A LAS file's CRS cannot be used the way lidarqa needs it.
    #[error("{}: {message}", path.display())]
    Crs {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// What is wrong, lowercase.
        message: String,
    },

    /// A file of fixed-size binary records (SBET, SMRMSG) whose size is not a whole number of
    /// records: a truncated or foreign file.
    #[error(
        "{}: size {size} bytes is not a multiple of the {record_len}-byte {kind} record",
        path.display()
    )]
    RecordSize {
        /// The file.
        path: PathBuf,
        /// The file size, bytes.
        size: u64,
        /// The record length, bytes.
        record_len: usize,
        /// The record kind (`sbet`, `smrmsg`).
        kind: &'static str,
    },

    /// A stream of fixed-size records ended in the middle of one.
    #[error(
        "{}: record {index}: stream ends after {bytes} of its {record_len} bytes",
        path.display()
    )]
    TruncatedRecord {
        /// The file (or stream name).
        path: PathBuf,
        /// Zero-based index of the incomplete record.
        index: u64,
        /// Bytes of the record that were present.
        bytes: usize,
        /// The record length, bytes.
        record_len: usize,
    },

    /// An Optech CSD header that is not one (signature, size, strip count, boresight angles).
    #[error("{}: CSD header: {message}", path.display())]
    CsdHeader {
        /// The CSD file.
        path: PathBuf,
        /// What is wrong, lowercase.
        message: String,
    },

    /// An Optech CSD record that is truncated or holds a value outside its physical range.
    #[error("{}: CSD record {index} (byte offset {offset}): {message}", path.display())]
    CsdRecord {
        /// The CSD file.
        path: PathBuf,
        /// Zero-based index of the record.
        index: u64,
        /// Byte offset of the record in the file.
        offset: u64,
        /// What is wrong, lowercase.
        message: String,
    },

    /// A time-ordered record whose time goes backwards or is not finite.
    #[error(
        "{}: record {index}: time {time_s} s is {reason} (previous record: {previous_s} s)",
        path.display()
    )]
    RecordTime {
        /// The file.
        path: PathBuf,
        /// Zero-based index of the record at fault.
        index: u64,
        /// Its time, seconds.
        time_s: f64,
        /// The previous record's time, seconds (NaN for the first record).
        previous_s: f64,
        /// `earlier than the previous record` or `not finite`.
        reason: &'static str,
    },

    /// A CSV file that could not be parsed as CSV (quoting, ragged rows, invalid UTF-8).
    #[error("{}: line {line}: {message}", path.display())]
    Csv {
        /// The CSV file.
        path: PathBuf,
        /// One-based line number.
        line: u64,
        /// The parser's message.
        message: String,
    },

    /// A CSV header without a required column.
    #[error("{}: line {line}: missing column `{column}`", path.display())]
    MissingColumn {
        /// The CSV file.
        path: PathBuf,
        /// One-based line number of the header.
        line: u64,
        /// The missing column name.
        column: String,
    },

    /// A CSV cell that should be a number and is not, or is NaN / infinite, or out of range.
    #[error("{}: line {line}: column `{column}`: {message}", path.display())]
    BadValue {
        /// The CSV file.
        path: PathBuf,
        /// One-based line number.
        line: u64,
        /// The column name.
        column: String,
        /// What is wrong with the value, quoting it.
        message: String,
    },

    /// A CSV key (point id, tie/strip pair) that appears twice.
    #[error("{}: line {line}: duplicate {what} `{key}` (first on line {first_line})", path.display())]
    DuplicateKey {
        /// The CSV file.
        path: PathBuf,
        /// One-based line of the second occurrence.
        line: u64,
        /// One-based line of the first occurrence.
        first_line: u64,
        /// What kind of key (`id`, `tie/strip pair`).
        what: &'static str,
        /// The repeated key.
        key: String,
    },

    /// A tie point picked in fewer than two strips (SPEC §7).
    #[error("{}: line {line}: tie `{tie}` is picked in only one strip; a tie needs two or more", path.display())]
    LonelyTie {
        /// The tie picks CSV.
        path: PathBuf,
        /// One-based line of its only pick.
        line: u64,
        /// The tie id.
        tie: String,
    },

    /// An output path that is also one of the inputs: writing it would destroy the input.
    #[error("{}: refusing to overwrite the input file {}", path.display(), input.display())]
    OutputIsInput {
        /// The output path as given.
        path: PathBuf,
        /// The input it resolves to.
        input: PathBuf,
    },

    /// The same input file given twice (same path, or two paths to one file): its points would
    /// count twice (an overlap of a strip with itself, duplicated tiles).
    #[error("{}: given twice (also as {}); give each input once", path.display(), first.display())]
    DuplicateInput {
        /// The second occurrence, as given.
        path: PathBuf,
        /// The first occurrence, as given.
        first: PathBuf,
    },

    /// Two inputs whose per-input outputs would have one path (same file name, one output
    /// directory): the second would replace the first.
    #[error(
        "{}: both {} and {} would be written here (same file name); rename one or run them separately",
        output.display(), first.display(), second.display()
    )]
    OutputClash {
        /// The output both map to.
        output: PathBuf,
        /// The first input.
        first: PathBuf,
        /// The second input.
        second: PathBuf,
    },

    /// A geoid grid (`--geoid`) that cannot be read or used.
    #[error("{}: {message}", path.display())]
    Geoid {
        /// The grid file.
        path: PathBuf,
        /// What is wrong and the likely cause.
        message: String,
    },

    /// Two outputs of one run that resolve to one file (another spelling, a link): the second
    /// would overwrite the first.
    #[error(
        "{}: also written as {} by this run; one output would overwrite the other",
        path.display(), other.display()
    )]
    OutputTwice {
        /// The output path as given.
        path: PathBuf,
        /// The other output it resolves to.
        other: PathBuf,
    },

    /// A LAS time that cannot be put on the trajectory's seconds-of-week time base.
    #[error("{}: {message}", path.display())]
    GpsTime {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// What is wrong, naming the value and the clue (week, date) at fault.
        message: String,
    },

    /// An EPSG code that is not one of the UTM zones lidarqa projects to.
    #[error(
        "EPSG:{epsg} is not a supported UTM CRS (supported: WGS 84 / UTM 32601–32660 north and \
         32701–32760 south, NAD83 / UTM 26901–26923)"
    )]
    UnsupportedEpsg {
        /// The code.
        epsg: u32,
    },

    /// A CRS lidarqa cannot compute in.
    #[error("{crs}: {message}")]
    UnsupportedCrs {
        /// The CRS, e.g. `EPSG:4326 (WGS 84)`.
        crs: String,
        /// Why, lowercase.
        message: String,
    },

    /// A UTM zone number outside 1–60.
    #[error("UTM zone {zone} is not in 1–60")]
    InvalidUtmZone {
        /// The zone number given.
        zone: u32,
    },

    /// A UTM zone that is not written like `33N` or `17S`.
    #[error("'{text}' is not a zone like 33N or 17S")]
    UtmZoneText {
        /// The text given.
        text: String,
    },

    /// A calendar date that does not exist or lies before the GPS epoch (1980-01-06).
    #[error("invalid date {year:04}-{month:02}-{day:02}: {message}")]
    InvalidDate {
        /// Year.
        year: i32,
        /// Month, 1–12.
        month: u32,
        /// Day of month, 1–31.
        day: u32,
        /// Why it is invalid.
        message: &'static str,
    },
    // The lead's sensor.rs (TOML sensor files) adds its variants here, e.g.
    // `Sensor { path, key, message }`; keep them path-carrying like the ones above.
    // --- sensor / config files (lead) ---
    /// A TOML configuration file (sensor, scenario) that cannot be used: bad syntax, an unknown key,
    /// a wrong unit suffix or a value out of range. `key` is the dotted key at fault when known.
    #[error("{}: {}{message}", path.display(), key.as_ref().map(|k| format!("key `{k}`: ")).unwrap_or_default())]
    Config {
        /// The file.
        path: PathBuf,
        /// The dotted key at fault (e.g. `sigma.range_deg`), when there is one.
        key: Option<String>,
        /// What is wrong, lowercase.
        message: String,
    },
}

/// The result type of lidarqa-io.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Wraps an I/O error with the path it happened on.
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// Wraps a `las` error with the path it happened on.
    pub(crate) fn las(path: impl Into<PathBuf>, source: las::Error) -> Self {
        Error::Las {
            path: path.into(),
            source,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_file_and_are_lowercase_without_period() {
        let e = Error::RecordSize {
            path: "a/sbet.out".into(),
            size: 137,
            record_len: 136,
            kind: "sbet",
        };
        assert_eq!(
            e.to_string(),
            "a/sbet.out: size 137 bytes is not a multiple of the 136-byte sbet record"
        );
        let e = Error::DuplicateKey {
            path: "c.csv".into(),
            line: 5,
            first_line: 2,
            what: "id",
            key: "T1".into(),
        };
        assert_eq!(
            e.to_string(),
            "c.csv: line 5: duplicate id `T1` (first on line 2)"
        );
        assert!(!e.to_string().ends_with('.'));
    }
}
