//! GPS time bases: LAS adjusted standard GPS time, GPS week + seconds of week, calendar dates.
//!
//! - **GPS time** counts SI seconds from the GPS epoch, 1980-01-06T00:00:00 (GPS = UTC then),
//!   without leap seconds. GPS week `w` starts at GPS time `w · 604800 s`.
//! - **LAS adjusted standard GPS time** (global encoding bit 0 set, LAS 1.2+) is GPS time − 10⁹ s
//!   (LAS 1.4 R15, §2.4 "Global Encoding"), which keeps microseconds in an f64 for decades.
//! - **LAS GPS week time** (bit 0 clear) is seconds of the GPS week, the week itself unstored.
//! - **SBET** times are GPS seconds of week (SPEC §7).
//!
//! Calendar dates here are GPS-time dates: GPS week 2200 starts on 2022-03-06 at 00:00:00 GPS
//! time, which is 2022-03-05T23:59:42 UTC (GPS − UTC = 18 s since 2017). A file's creation
//! date (LAS header: day of year and year, UTC by the spec) is therefore never used to pick a
//! week to the second; it is only a consistency clue, see [`LasTimeConverter`].

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// The offset of LAS adjusted standard GPS time: adjusted = GPS time − 10⁹ s.
pub const ADJUSTED_GPS_OFFSET_S: f64 = 1.0e9;

/// Seconds in a GPS week.
pub const SECONDS_PER_WEEK_S: f64 = 604_800.0;

/// Days from 1970-01-01 to the GPS epoch 1980-01-06.
const GPS_EPOCH_UNIX_DAYS: i64 = 3657;

/// How a LAS file stores GPS time (global encoding bit 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LasTimeBase {
    /// Bit 0 clear: GPS seconds of week, the week not recorded.
    GpsWeekSeconds,
    /// Bit 0 set: adjusted standard GPS time = GPS time − 10⁹ s.
    AdjustedStandard,
}

/// A proleptic Gregorian calendar date (no time of day).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct CivilDate {
    /// Year, e.g. 2022.
    pub year: i32,
    /// Month, 1–12.
    pub month: u32,
    /// Day of month, 1–31.
    pub day: u32,
}

impl std::fmt::Display for CivilDate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:04}-{:02}-{:02}", self.year, self.month, self.day)
    }
}

fn is_leap(year: i32) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

fn days_in_month(year: i32, month: u32) -> u32 {
    match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if is_leap(year) => 29,
        2 => 28,
        _ => 0,
    }
}

impl CivilDate {
    /// A checked date.
    ///
    /// # Errors
    /// [`Error::InvalidDate`] when the month or day does not exist.
    pub fn new(year: i32, month: u32, day: u32) -> Result<Self> {
        if !(1..=12).contains(&month) || day == 0 || day > days_in_month(year, month) {
            return Err(Error::InvalidDate {
                year,
                month,
                day,
                message: "no such day",
            });
        }
        Ok(CivilDate { year, month, day })
    }

    /// The date of day-of-year `day_of_year` (1 = 1 January), as the LAS header stores it.
    ///
    /// # Errors
    /// [`Error::InvalidDate`] when the day is 0 or past the year's end.
    pub fn from_year_day(year: i32, day_of_year: u32) -> Result<Self> {
        let len = if is_leap(year) { 366 } else { 365 };
        if day_of_year == 0 || day_of_year > len {
            return Err(Error::InvalidDate {
                year,
                month: 1,
                day: day_of_year,
                message: "day of year out of range",
            });
        }
        let jan1 = CivilDate {
            year,
            month: 1,
            day: 1,
        };
        Ok(CivilDate::from_unix_days(
            jan1.unix_days() + i64::from(day_of_year) - 1,
        ))
    }

    /// Days since 1970-01-01 (negative before). H. Hinnant's `days_from_civil` algorithm.
    pub fn unix_days(&self) -> i64 {
        let y = i64::from(self.year) - i64::from(self.month <= 2);
        let era = y.div_euclid(400);
        let yoe = y - era * 400;
        let m = i64::from(self.month);
        let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + i64::from(self.day) - 1;
        let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
        era * 146_097 + doe - 719_468
    }

    /// The date `days` days after 1970-01-01. H. Hinnant's `civil_from_days` algorithm.
    pub fn from_unix_days(days: i64) -> Self {
        let z = days + 719_468;
        let era = z.div_euclid(146_097);
        let doe = z - era * 146_097;
        let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
        let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
        let mp = (5 * doy + 2) / 153;
        let day = doy - (153 * mp + 2) / 5 + 1;
        let month = if mp < 10 { mp + 3 } else { mp - 9 };
        let year = yoe + era * 400 + i64::from(month <= 2);
        // The ranges are guaranteed by the algorithm: day 1–31, month 1–12.
        CivilDate {
            year: year as i32,
            month: month as u32,
            day: day as u32,
        }
    }
}

/// A GPS time as week number and seconds into the week.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpsWeekTime {
    /// Full GPS week number since 1980-01-06 (no 1024-week rollover).
    pub week: i64,
    /// Seconds since the start of the week, in [0, 604800).
    pub seconds_of_week_s: f64,
}

/// Splits LAS adjusted standard GPS time (s) into GPS week and seconds of week.
///
/// week = ⌊(t + 10⁹) / 604800⌋, sow = t − (week · 604800 − 10⁹). The second form subtracts two
/// exact integers-as-f64 from `t`, so no precision is lost to the 10⁹ offset.
///
/// ```
/// use lidarqa_io::adjusted_standard_to_week;
/// // 2022-03-06T00:00:10 GPS: week 2200 starts at GPS time 2200·604800 = 1 330 560 000 s.
/// let w = adjusted_standard_to_week(330_560_010.25);
/// assert_eq!(w.week, 2200);
/// assert_eq!(w.seconds_of_week_s, 10.25);
/// ```
#[inline]
pub fn adjusted_standard_to_week(adjusted_s: f64) -> GpsWeekTime {
    let week = lidarqa_model::floor_f64((adjusted_s + ADJUSTED_GPS_OFFSET_S) / SECONDS_PER_WEEK_S);
    let mut sow = adjusted_s - (week * SECONDS_PER_WEEK_S - ADJUSTED_GPS_OFFSET_S);
    let mut week = week as i64;
    // Guard the floor against rounding at a week boundary.
    if sow < 0.0 {
        sow += SECONDS_PER_WEEK_S;
        week -= 1;
    } else if sow >= SECONDS_PER_WEEK_S {
        sow -= SECONDS_PER_WEEK_S;
        week += 1;
    }
    GpsWeekTime {
        week,
        seconds_of_week_s: sow,
    }
}

/// LAS adjusted standard GPS time (s) of GPS week `week` at `seconds_of_week_s`.
///
/// adjusted = week · 604800 + sow − 10⁹.
pub fn week_to_adjusted_standard(week: i64, seconds_of_week_s: f64) -> f64 {
    (week as f64 * SECONDS_PER_WEEK_S - ADJUSTED_GPS_OFFSET_S) + seconds_of_week_s
}

/// The GPS week that contains the (GPS-time) date.
///
/// # Errors
/// [`Error::InvalidDate`] for a date before the GPS epoch, 1980-01-06.
///
/// ```
/// use lidarqa_io::{gps_week_of_date, CivilDate};
/// assert_eq!(gps_week_of_date(CivilDate::new(2022, 3, 6).unwrap()).unwrap(), 2200); // Sunday
/// assert_eq!(gps_week_of_date(CivilDate::new(2022, 3, 5).unwrap()).unwrap(), 2199); // Saturday
/// ```
pub fn gps_week_of_date(date: CivilDate) -> Result<i64> {
    let days = date.unix_days() - GPS_EPOCH_UNIX_DAYS;
    if days < 0 {
        return Err(Error::InvalidDate {
            year: date.year,
            month: date.month,
            day: date.day,
            message: "before the GPS epoch 1980-01-06",
        });
    }
    Ok(days / 7)
}

/// The (GPS-time) date on which GPS week `week` starts, a Sunday.
pub fn gps_week_start(week: i64) -> CivilDate {
    CivilDate::from_unix_days(GPS_EPOCH_UNIX_DAYS + 7 * week)
}

/// Puts LAS point times on the SBET's time base (GPS seconds of week), refusing to guess.
///
/// The clues and how they are used:
///
/// | LAS time base | `--gps-week W` given | no `--gps-week` |
/// |---|---|---|
/// | adjusted standard | sow = t + 10⁹ − W·604800; an error unless in [0, 604800), i.e. unless the point lies in week W | the point's own week (the time is absolute); an error if that week is after the week of the file's creation date: the file cannot have been written before its points were measured, so one of the two clues is wrong |
/// | GPS week time | t itself; W cannot be checked against the data | t itself |
///
/// and in every case a result outside [0, 604800) or not finite is an error naming the file and
/// the value. The creation date never chooses the week: it is the day the file was written,
/// often days after the flight. A survey crossing a week boundary (Saturday/Sunday midnight GPS)
/// must be split, or converted with `--gps-week` and an SBET that counts past 604800 s, which
/// this converter refuses on purpose.
#[derive(Clone, Debug)]
pub struct LasTimeConverter {
    path: PathBuf,
    base: LasTimeBase,
    week_flag: Option<i64>,
    /// The week came from the trajectory's own adjusted standard times, not `--gps-week`.
    week_from_trajectory: bool,
    creation: Option<(CivilDate, i64)>,
}

impl LasTimeConverter {
    /// A converter for the LAS file `path`.
    ///
    /// `gps_week` is the user's `--gps-week`, `creation_date` the header's file creation date.
    ///
    /// # Errors
    /// [`Error::GpsTime`] when `gps_week` is negative.
    pub fn new(
        path: impl AsRef<Path>,
        base: LasTimeBase,
        gps_week: Option<i64>,
        creation_date: Option<CivilDate>,
    ) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        if let Some(w) = gps_week {
            if w < 0 {
                return Err(Error::GpsTime {
                    path,
                    message: format!("GPS week {w} is negative"),
                });
            }
        }
        // A creation date before the GPS epoch is garbage in the header; it is no clue.
        let creation = creation_date.and_then(|d| gps_week_of_date(d).ok().map(|w| (d, w)));
        Ok(LasTimeConverter {
            path,
            base,
            week_flag: gps_week,
            week_from_trajectory: false,
            creation,
        })
    }

    /// Without `--gps-week`, the week of a trajectory whose adjusted standard GPS times carry
    /// one: points in adjusted standard time of another week are then refused naming both
    /// weeks (their seconds of week would match another day's aircraft).
    pub fn with_trajectory_week(mut self, week: Option<i64>) -> Self {
        if self.week_flag.is_none()
            && let Some(w) = week
        {
            self.week_flag = Some(w);
            self.week_from_trajectory = true;
        }
        self
    }

    /// The LAS time base this converter reads.
    pub fn base(&self) -> LasTimeBase {
        self.base
    }

    /// LAS GPS time `t_las_s` (seconds, in the file's time base) as GPS seconds of week.
    ///
    /// # Errors
    /// [`Error::GpsTime`] naming the file and the value, as described on the type.
    #[inline]
    pub fn to_seconds_of_week(&self, t_las_s: f64) -> Result<f64> {
        // Inlined per point: the messages are built out of line, only for a bad time.
        if !t_las_s.is_finite() {
            return Err(self.err(format!("GPS time {t_las_s} is not finite")));
        }
        match (self.base, self.week_flag) {
            (LasTimeBase::GpsWeekSeconds, _) => {
                if (0.0..SECONDS_PER_WEEK_S).contains(&t_las_s) {
                    Ok(t_las_s)
                } else {
                    Err(self.err(format!(
                        "GPS time {t_las_s} s is outside [0, 604800) although the header says \
                         GPS week time (global encoding bit 0 clear); is it adjusted standard time?"
                    )))
                }
            }
            (LasTimeBase::AdjustedStandard, Some(w)) => {
                let sow = t_las_s - (w as f64 * SECONDS_PER_WEEK_S - ADJUSTED_GPS_OFFSET_S);
                if (0.0..SECONDS_PER_WEEK_S).contains(&sow) {
                    Ok(sow)
                } else {
                    Err(self.not_in_given_week(t_las_s, w, sow))
                }
            }
            (LasTimeBase::AdjustedStandard, None) => {
                let own = adjusted_standard_to_week(t_las_s);
                match self.creation {
                    Some((date, cw)) if own.week > cw => Err(self.err(format!(
                        "adjusted standard GPS time {t_las_s} s lies in GPS week {} (starting \
                         {}), after the file creation date {date} (week {cw}); the clues \
                         disagree: pass --gps-week",
                        own.week,
                        gps_week_start(own.week)
                    ))),
                    _ => Ok(own.seconds_of_week_s),
                }
            }
        }
    }

    /// The error of an adjusted standard time outside the week `--gps-week` gives.
    #[cold]
    fn not_in_given_week(&self, t_las_s: f64, w: i64, sow: f64) -> Error {
        let own = adjusted_standard_to_week(t_las_s);
        if self.week_from_trajectory {
            return self.err(format!(
                "adjusted standard GPS time {t_las_s} s lies in GPS week {} (starting {}), not \
                 in week {w} (starting {}) of the trajectory's adjusted standard GPS times: a \
                 trajectory of another day's flight?",
                own.week,
                gps_week_start(own.week),
                gps_week_start(w)
            ));
        }
        self.err(format!(
            "adjusted standard GPS time {t_las_s} s lies in GPS week {} (starting {}), \
             not in week {w} given by --gps-week: {sow} s is outside [0, 604800)",
            own.week,
            gps_week_start(own.week)
        ))
    }

    #[cold]
    fn err(&self, message: String) -> Error {
        Error::GpsTime {
            path: self.path.clone(),
            message,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(y: i32, m: u32, day: u32) -> CivilDate {
        CivilDate::new(y, m, day).unwrap()
    }

    #[test]
    fn calendar_round_trip_and_known_days() {
        assert_eq!(d(1970, 1, 1).unix_days(), 0);
        assert_eq!(d(1980, 1, 6).unix_days(), GPS_EPOCH_UNIX_DAYS);
        // 2000-03-01: 30 years of 365 days + 7 leap days (72..96) + Jan 31 + Feb 29 (2000 is leap).
        assert_eq!(d(2000, 3, 1).unix_days(), 30 * 365 + 7 + 31 + 29);
        for days in [-800_000_i64, -1, 0, 59, 10_957, 19_057, 2_932_896] {
            assert_eq!(CivilDate::from_unix_days(days).unix_days(), days);
        }
    }

    #[test]
    fn year_day_matches_month_day() {
        assert_eq!(CivilDate::from_year_day(2022, 65).unwrap(), d(2022, 3, 6));
        assert_eq!(CivilDate::from_year_day(2024, 60).unwrap(), d(2024, 2, 29));
        assert_eq!(
            CivilDate::from_year_day(2023, 365).unwrap(),
            d(2023, 12, 31)
        );
        assert!(CivilDate::from_year_day(2023, 366).is_err());
        assert!(CivilDate::from_year_day(2023, 0).is_err());
        assert!(CivilDate::new(2023, 2, 29).is_err());
        assert!(CivilDate::new(2023, 13, 1).is_err());
    }

    /// Hand computation: week 2200 starts 2200 · 7 = 15400 days after 1980-01-06.
    /// 1980-01-06 is Unix day 3657; 3657 + 15400 = 19057; 2022-01-01 is Unix day 18993
    /// (52 · 365 + 13 leap days 1972…2020 = 18993), and 19057 − 18993 = 64 days later
    /// is 2022-03-06 (Jan 31 + Feb 28 = 59 ⇒ 1 March is day 59, 6 March day 64), a Sunday.
    #[test]
    fn week_2200_starts_2022_03_06() {
        assert_eq!(d(2022, 1, 1).unix_days(), 18_993);
        assert_eq!(gps_week_start(2200), d(2022, 3, 6));
        assert_eq!(gps_week_start(0), d(1980, 1, 6));
        // Week 1024 (first rollover) started 1999-08-22.
        assert_eq!(gps_week_start(1024), d(1999, 8, 22));
        // Week 2048 (second rollover) started 2019-04-07.
        assert_eq!(gps_week_start(2048), d(2019, 4, 7));
        assert_eq!(gps_week_of_date(d(2022, 3, 12)).unwrap(), 2200);
        assert_eq!(gps_week_of_date(d(2022, 3, 13)).unwrap(), 2201);
        assert!(gps_week_of_date(d(1980, 1, 5)).is_err());
    }

    #[test]
    fn adjusted_standard_and_week_time() {
        // GPS time 10⁹ s (adjusted 0): 1653 · 604800 = 999 734 400, so week 1653 and
        // sow 265 600 s = 3 d 1 h 46 min 40 s, i.e. Wednesday 2011-09-14T01:46:40 GPS time, the
        // well-known "GPS second one billion" (01:46:25 UTC with the 15 leap seconds of 2011).
        let w = adjusted_standard_to_week(0.0);
        assert_eq!(w.week, 1653);
        assert_eq!(w.seconds_of_week_s, 265_600.0);
        assert_eq!(gps_week_start(1653), d(2011, 9, 11));
        // Negative adjusted time (data before 2011-09-14) is valid.
        let w = adjusted_standard_to_week(-265_600.5);
        assert_eq!((w.week, w.seconds_of_week_s), (1652, 604_799.5));
        // Exact week boundary.
        let t = week_to_adjusted_standard(2200, 0.0);
        assert_eq!(t, 330_560_000.0);
        let w = adjusted_standard_to_week(t);
        assert_eq!((w.week, w.seconds_of_week_s), (2200, 0.0));
        // Round trip keeps microseconds.
        let t = week_to_adjusted_standard(2200, 123_456.789_012);
        let w = adjusted_standard_to_week(t);
        assert_eq!(w.week, 2200);
        assert!((w.seconds_of_week_s - 123_456.789_012).abs() < 1e-6);
    }

    #[test]
    fn converter_adjusted_standard_with_flag() {
        let t = week_to_adjusted_standard(2200, 3600.5);
        let c = LasTimeConverter::new("a.las", LasTimeBase::AdjustedStandard, Some(2200), None)
            .unwrap();
        assert_eq!(c.to_seconds_of_week(t).unwrap(), 3600.5);
        // Flag says 2201: the point is in 2200 ⇒ sow −600 000 s, outside ⇒ error naming both.
        let c = LasTimeConverter::new("a.las", LasTimeBase::AdjustedStandard, Some(2201), None)
            .unwrap();
        let e = c.to_seconds_of_week(t).unwrap_err().to_string();
        assert!(e.starts_with("a.las: "), "{e}");
        assert!(e.contains("week 2200") && e.contains("week 2201"), "{e}");
        assert!(e.contains(&t.to_string()), "{e}");
    }

    #[test]
    fn converter_adjusted_standard_with_creation_date() {
        let t = week_to_adjusted_standard(2200, 86_400.0);
        // Created the same week or later: consistent.
        for date in [d(2022, 3, 7), d(2022, 4, 1)] {
            let c = LasTimeConverter::new("b.laz", LasTimeBase::AdjustedStandard, None, Some(date))
                .unwrap();
            assert_eq!(c.to_seconds_of_week(t).unwrap(), 86_400.0);
        }
        // Created before the data was measured: the clues disagree.
        let c = LasTimeConverter::new(
            "b.laz",
            LasTimeBase::AdjustedStandard,
            None,
            Some(d(2022, 3, 1)),
        )
        .unwrap();
        let e = c.to_seconds_of_week(t).unwrap_err().to_string();
        assert!(e.contains("b.laz") && e.contains("2022-03-01") && e.contains("disagree"));
        // With --gps-week the flag wins over the creation date.
        let c = LasTimeConverter::new(
            "b.laz",
            LasTimeBase::AdjustedStandard,
            Some(2200),
            Some(d(2022, 3, 1)),
        )
        .unwrap();
        assert_eq!(c.to_seconds_of_week(t).unwrap(), 86_400.0);
    }

    #[test]
    fn converter_week_time() {
        let c = LasTimeConverter::new("c.las", LasTimeBase::GpsWeekSeconds, None, None).unwrap();
        assert_eq!(c.to_seconds_of_week(0.0).unwrap(), 0.0);
        assert_eq!(c.to_seconds_of_week(604_799.9).unwrap(), 604_799.9);
        for bad in [604_800.0, -0.1, 330_560_000.0, f64::NAN] {
            let e = c.to_seconds_of_week(bad).unwrap_err().to_string();
            assert!(e.starts_with("c.las: "), "{e}");
        }
        assert!(
            LasTimeConverter::new("c.las", LasTimeBase::GpsWeekSeconds, Some(-1), None).is_err()
        );
    }
}
