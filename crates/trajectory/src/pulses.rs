//! Pulses: returns grouped by (strip, GPS time), checked, and turned into first–last lines.

use crate::{PulseChecks, ReturnPoint};
use lidarqa_model::Warning;
use nalgebra::Vector3;

/// A first–last return line: through `a` (the last return) along the unit vector `d` towards
/// the sensor.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Line {
    pub(crate) time_s: f64,
    pub(crate) a: Vector3<f64>,
    pub(crate) d: Vector3<f64>,
    pub(crate) separation_m: f64,
}

pub(crate) fn check_warnings(c: &PulseChecks) -> Vec<Warning> {
    let mut w = Vec::new();
    let share = |n: u64| 100.0 * n as f64 / c.pulses.max(1) as f64;
    if c.ambiguous_times > 0 {
        w.push(Warning::new(
            "gps_time_not_unique",
            format!(
                "{} of {} GPS times ({:.1} %) carry more returns than their pulse has or two \
                 returns with the same number: the times do not identify pulses (rounded times, \
                 merged channels?); those pulses are not used",
                c.ambiguous_times,
                c.pulses,
                share(c.ambiguous_times)
            ),
        ));
    }
    if c.out_of_order > 0 {
        w.push(Warning::new(
            "returns_out_of_order",
            format!(
                "{} pulses ({:.1} %) have return numbers out of range or disagreeing, or a first \
                 return below the last; not used",
                c.out_of_order,
                share(c.out_of_order)
            ),
        ));
    }
    if c.split_across_strips > 0 {
        w.push(Warning::new(
            "pulse_split_across_strips",
            format!(
                "{} GPS times occur in more than one strip (point source id or file): each \
                 strip's returns are used as separate pulses; check that the strips are not \
                 copies or retiled pieces of one another",
                c.split_across_strips
            ),
        ));
    }
    if c.incomplete > 0 {
        w.push(Warning::new(
            "pulse_returns_missing",
            format!(
                "{} multi-return pulses lack their first or last return (thinned or clipped \
                 data); not used",
                c.incomplete
            ),
        ));
    }
    w
}

/// Groups returns into pulses, checks them, and returns the lines per strip (time order).
pub(crate) fn pulse_lines(
    points: &[ReturnPoint],
    min_sep: f64,
) -> (Vec<(u32, Vec<Line>)>, PulseChecks) {
    let mut c = PulseChecks {
        returns: points.len() as u64,
        ..PulseChecks::default()
    };
    let mut idx: Vec<usize> = (0..points.len()).collect();
    let key = |i: usize| (points[i].strip, points[i].time_s, points[i].return_number);
    idx.sort_by(|&i, &j| {
        key(i)
            .partial_cmp(&key(j))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut out: Vec<(u32, Vec<Line>)> = Vec::new();
    let mut start = 0;
    while start < idx.len() {
        let p0 = &points[idx[start]];
        let mut end = start + 1;
        while end < idx.len() {
            let p = &points[idx[end]];
            if p.strip != p0.strip || p.time_s != p0.time_s {
                break;
            }
            end += 1;
        }
        c.pulses += 1;
        let group: Vec<&ReturnPoint> = idx[start..end].iter().map(|&i| &points[i]).collect();
        start = end;
        let n = group[0].number_of_returns;
        let numbers_bad = group
            .iter()
            .any(|p| p.return_number == 0 || p.return_number > p.number_of_returns)
            || group.iter().any(|p| p.number_of_returns != n);
        let duplicate = group
            .windows(2)
            .any(|w| w[0].return_number == w[1].return_number);
        if group.len() > usize::from(n.max(1)) || duplicate {
            c.ambiguous_times += 1;
            continue;
        }
        if numbers_bad {
            c.out_of_order += 1;
            continue;
        }
        if n < 2 {
            continue;
        }
        let (Some(first), Some(last)) = (
            group.iter().find(|p| p.return_number == 1),
            group.iter().find(|p| p.return_number == n),
        ) else {
            c.incomplete += 1;
            continue;
        };
        let f = Vector3::from(first.position_m);
        let l = Vector3::from(last.position_m);
        let v = f - l;
        if v.z <= 0.0 {
            c.out_of_order += 1;
            continue;
        }
        c.multi_return_pulses += 1;
        let sep = v.norm();
        if sep < min_sep {
            c.too_short += 1;
            continue;
        }
        let line = Line {
            time_s: first.time_s,
            a: l,
            d: v / sep,
            separation_m: sep,
        };
        match out.last_mut() {
            Some((s, v)) if *s == first.strip => v.push(line),
            _ => out.push((first.strip, vec![line])),
        }
    }
    // The same GPS time in two strips.
    let mut times: Vec<(f64, u32)> = points.iter().map(|p| (p.time_s, p.strip)).collect();
    times.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    times.dedup();
    c.split_across_strips = times.windows(2).filter(|w| w[0].0 == w[1].0).count() as u64;
    (out, c)
}
