//! Inline SVG plots made with plotters (SVG backend only; text stays `<text>`, so no fonts are
//! needed and the page's CSS font applies).
//!
//! Every function returns the `<svg>` element (with an `id`, `class="plot"` and an `aria-label`),
//! or, if plotters fails, a short HTML note: a plot never panics the report.

use crate::text::esc;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Width of every plot, px (the page is 900 px wide with padding).
pub(crate) const WIDTH: u32 = 860;

type DynResult = std::result::Result<(), Box<dyn std::error::Error>>;
type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

const FONT: &str = "sans-serif";
const TITLE_SIZE: i32 = 22;
const DESC_SIZE: i32 = 18;
const TICK_SIZE: i32 = 16;
const TEXT: RGBColor = RGBColor(34, 34, 34);
const GRID_LIGHT: RGBColor = RGBColor(236, 236, 236);
const GRID_BOLD: RGBColor = RGBColor(205, 205, 205);

/// Tableau-10, the colours every series uses in order.
pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Draws one SVG of `w × h` px with `draw`, and tags it for the page.
fn svg(id: &str, title: &str, w: u32, h: u32, draw: impl FnOnce(&Area) -> DynResult) -> String {
    let mut buf = String::new();
    let result: DynResult = (|| {
        let root = SVGBackend::with_string(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
        Ok(())
    })();
    match result {
        Ok(()) => {
            // Inline SVG in HTML needs no namespace; dropping it keeps the page free of URLs.
            let body = buf.replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1);
            body.replacen(
                "<svg ",
                &format!(
                    "<svg id=\"{}\" class=\"plot\" role=\"img\" aria-label=\"{}\" ",
                    esc(id),
                    esc(title)
                ),
                1,
            )
        }
        Err(e) => format!(
            "<p class=\"warn\">The plot “{}” could not be drawn: {}</p>",
            esc(title),
            esc(&e.to_string())
        ),
    }
}

fn font(size: i32) -> TextStyle<'static> {
    (FONT, size).into_font().color(&TEXT)
}

/// The plot's title above `root`; returns the area below it.
fn titled<'a>(
    root: &Area<'a>,
    title: &str,
) -> std::result::Result<Area<'a>, Box<dyn std::error::Error>> {
    Ok(root.titled(title, font(TITLE_SIZE))?)
}

/// A padded range around the finite values of `values` (optionally including 0).
pub(crate) fn span(
    values: impl IntoIterator<Item = f64>,
    include_zero: bool,
    pad: f64,
) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.into_iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if include_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    if hi - lo < 1e-12 {
        let d = if hi.abs() > 1e-12 {
            hi.abs() * 0.1
        } else {
            1.0
        };
        return (lo - d, hi + d);
    }
    let d = (hi - lo) * pad;
    let lo2 = if include_zero && lo >= 0.0 {
        lo
    } else {
        lo - d
    };
    let hi2 = if include_zero && hi <= 0.0 {
        hi
    } else {
        hi + d
    };
    (lo2, hi2)
}

/// A 1-2-5 "nice" number near `x` (> 0).
pub(crate) fn nice(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    let m = x / p;
    let n = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    };
    n * p
}

/// Decimals that tick labels over `lo..hi` need (about 10 ticks).
pub(crate) fn decimals(lo: f64, hi: f64) -> usize {
    // plotters labels at the smallest 1-2-5 step giving at most 10 labels.
    let x = (hi - lo).abs() / 10.0;
    if !(x.is_finite() && x > 0.0) {
        return 1;
    }
    let p = 10f64.powf(x.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= x * (1.0 - 1e-9))
        .unwrap_or(10.0 * p);
    (-(step.log10() + 1e-9).floor()).clamp(0.0, 6.0) as usize
}

/// A tick label with `d` decimals, never "-0".
pub(crate) fn tick(v: f64, d: usize) -> String {
    let t = format!("{v:.d$}");
    if t.starts_with('-') && t[1..].chars().all(|c| c == '0' || c == '.') {
        t[1..].to_string()
    } else {
        t
    }
}

macro_rules! mesh {
    ($chart:expr) => {
        $chart
            .configure_mesh()
            .label_style(font(TICK_SIZE))
            .axis_desc_style(font(DESC_SIZE))
            .light_line_style(GRID_LIGHT)
            .max_light_lines(4)
            .bold_line_style(GRID_BOLD)
            .axis_style(RGBColor(90, 90, 90))
    };
}

macro_rules! legend {
    ($chart:expr, $pos:expr) => {
        $chart
            .configure_series_labels()
            .position($pos)
            .label_font(font(TICK_SIZE))
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(180, 180, 180))
            .draw()?
    };
}

// ---------------------------------------------------------------------------------------------

/// Horizontal grouped bars: for each category, one bar per series (values in the x unit).
pub(crate) fn hbars(
    id: &str,
    title: &str,
    x_desc: &str,
    categories: &[String],
    series: &[(&str, Vec<f64>)],
) -> String {
    let n = categories.len().max(1);
    let h = 130 + 30 * n as u32;
    let longest = categories
        .iter()
        .map(|c| c.chars().count())
        .max()
        .unwrap_or(4);
    let label_w = (longest as u32 * 8 + 24).clamp(60, 240);
    let max = series
        .iter()
        .flat_map(|(_, v)| v.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let xmax = if max > 0.0 { max * 1.12 } else { 1.0 };
    svg(id, title, WIDTH, h, |root| {
        let area = titled(root, title)?;
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(label_w)
            .build_cartesian_2d(0.0..xmax, -0.5..(n as f64 - 0.5))?;
        let name_at = |v: &f64| {
            let i = v.round();
            if (v - i).abs() > 1e-6 || i < 0.0 || i as usize >= n {
                return String::new();
            }
            categories
                .get(n - 1 - i as usize)
                .cloned()
                .unwrap_or_default()
        };
        let dx = decimals(0.0, xmax);
        let xfmt = |v: &f64| tick(*v, dx);
        mesh!(chart)
            .disable_y_mesh()
            .y_labels(n + 2)
            .y_label_formatter(&name_at)
            .x_label_formatter(&xfmt)
            .x_desc(x_desc)
            .draw()?;
        let k = series.len().max(1) as f64;
        let band = 0.8 / k;
        for (s, (name, values)) in series.iter().enumerate() {
            let color = PALETTE[s % PALETTE.len()];
            chart
                .draw_series(values.iter().enumerate().map(|(i, &v)| {
                    let y = (n - 1 - i) as f64 + 0.4 - band * (s as f64 + 1.0);
                    let v = if v.is_finite() { v.max(0.0) } else { 0.0 };
                    Rectangle::new(
                        [(0.0, y + 0.06 * band), (v, y + 0.94 * band)],
                        color.filled(),
                    )
                }))?
                .label(*name)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 14, y + 5)], color.filled())
                });
        }
        legend!(chart, SeriesLabelPosition::LowerRight);
        Ok(())
    })
}

/// One line series: name, colour index, points (x, y; `None` breaks the line), dashed.
pub(crate) struct Line {
    pub name: String,
    pub color: usize,
    pub points: Vec<(f64, Option<f64>)>,
    pub dashed: bool,
    pub markers: bool,
}

/// A line chart; `y_range` fixes the y axis (to compare two charts), else it fits the data.
#[allow(clippy::too_many_arguments)]
pub(crate) fn lines(
    id: &str,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[Line],
    y_range: Option<(f64, f64)>,
    include_zero: bool,
    height: u32,
) -> String {
    let (x0, x1) = span(
        series.iter().flat_map(|s| s.points.iter().map(|p| p.0)),
        false,
        0.0,
    );
    let (y0, y1) = y_range.unwrap_or_else(|| {
        span(
            series
                .iter()
                .flat_map(|s| s.points.iter().filter_map(|p| p.1)),
            include_zero,
            0.08,
        )
    });
    svg(id, title, WIDTH, height, |root| {
        let area = titled(root, title)?;
        let mut chart = ChartBuilder::on(&area)
            .margin(14)
            .x_label_area_size(50)
            .y_label_area_size(78)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        let (dx, dy) = (decimals(x0, x1), decimals(y0, y1));
        let xfmt = |v: &f64| tick(*v, dx);
        let yfmt = |v: &f64| tick(*v, dy);
        mesh!(chart)
            .x_label_formatter(&xfmt)
            .y_label_formatter(&yfmt)
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()?;
        if y0 < 0.0 && y1 > 0.0 {
            chart.draw_series(LineSeries::new(
                vec![(x0, 0.0), (x1, 0.0)],
                RGBColor(120, 120, 120).stroke_width(1),
            ))?;
        }
        for s in series {
            let color = PALETTE[s.color % PALETTE.len()];
            let style = color.stroke_width(2);
            // Contiguous runs of defined values.
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for &(x, y) in &s.points {
                match y {
                    Some(y) if y.is_finite() && x.is_finite() => {
                        runs.last_mut().unwrap_or(&mut Vec::new()).push((x, y))
                    }
                    _ => {
                        if runs.last().is_some_and(|r| !r.is_empty()) {
                            runs.push(Vec::new());
                        }
                    }
                }
            }
            let mut first = true;
            for run in runs.into_iter().filter(|r| !r.is_empty()) {
                let anno = if s.dashed {
                    chart.draw_series(DashedLineSeries::new(run.clone(), 8, 5, style))?
                } else {
                    chart.draw_series(LineSeries::new(run.clone(), style))?
                };
                if first {
                    let dashed = s.dashed;
                    anno.label(s.name.clone()).legend(move |(x, y)| {
                        if dashed {
                            PathElement::new(vec![(x, y), (x + 8, y)], style)
                        } else {
                            PathElement::new(vec![(x, y), (x + 22, y)], style)
                        }
                    });
                    first = false;
                }
                if s.markers {
                    chart.draw_series(run.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
                }
            }
        }
        if series.len() > 1 {
            legend!(chart, legend_corner(series, (x0, x1), (y0, y1)));
        }
        Ok(())
    })
}

/// The corner of the plot where the legend (about 25 % × 30 % of it) hides the fewest points.
fn legend_corner(
    series: &[Line],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> SeriesLabelPosition {
    let corners = [
        (SeriesLabelPosition::UpperRight, true, true),
        (SeriesLabelPosition::UpperLeft, false, true),
        (SeriesLabelPosition::LowerRight, true, false),
        (SeriesLabelPosition::LowerLeft, false, false),
    ];
    let hidden = |right: bool, upper: bool| {
        series
            .iter()
            .flat_map(|s| {
                // Sample the segments too, not only the vertices.
                s.points.windows(2).flat_map(|w| {
                    (0..=4).filter_map(move |k| {
                        let t = k as f64 / 4.0;
                        let (a, b) = (w[0], w[1]);
                        Some((a.0 + (b.0 - a.0) * t, a.1? + (b.1? - a.1?) * t))
                    })
                })
            })
            .filter(|&(x, y)| {
                let fx = (x - x0) / (x1 - x0);
                let fy = (y - y0) / (y1 - y0);
                (if right { fx > 0.72 } else { fx < 0.28 })
                    && (if upper { fy > 0.68 } else { fy < 0.32 })
            })
            .count()
    };
    corners
        .into_iter()
        .min_by_key(|&(_, r, u)| hidden(r, u))
        .map(|c| c.0)
        .unwrap_or(SeriesLabelPosition::UpperRight)
}

/// A histogram from explicit bin edges; `marker` draws a labelled vertical line (e.g. the p95).
pub(crate) fn histogram(
    id: &str,
    title: &str,
    x_desc: &str,
    edges: &[f64],
    counts: &[u64],
    marker: Option<(f64, String)>,
) -> String {
    let (x0, x1) = (
        edges.first().copied().unwrap_or(0.0),
        edges.last().copied().unwrap_or(1.0),
    );
    let (x0, x1) = if x1 > x0 {
        (x0, x1)
    } else {
        (x0 - 1.0, x0 + 1.0)
    };
    let ymax = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.1;
    svg(id, title, WIDTH, 340, |root| {
        let area = titled(root, title)?;
        let mut chart = ChartBuilder::on(&area)
            .margin(14)
            .x_label_area_size(50)
            .y_label_area_size(78)
            .build_cartesian_2d(x0..x1, 0.0..ymax)?;
        let count_fmt = |v: &f64| {
            if *v >= 1e6 {
                format!("{:.1}M", v / 1e6)
            } else if *v >= 1e4 {
                format!("{:.0}k", v / 1e3)
            } else {
                format!("{v:.0}")
            }
        };
        let dx = decimals(x0, x1);
        let xfmt = |v: &f64| tick(*v, dx);
        mesh!(chart)
            .disable_x_mesh()
            .x_label_formatter(&xfmt)
            .x_desc(x_desc)
            .y_desc("points")
            .y_label_formatter(&count_fmt)
            .draw()?;
        chart.draw_series(counts.iter().enumerate().map(|(i, &c)| {
            Rectangle::new(
                [(edges[i], 0.0), (edges[i + 1], c as f64)],
                PALETTE[0].mix(0.85).filled(),
            )
        }))?;
        if let Some((x, label)) = marker
            && x.is_finite()
        {
            let red = PALETTE[3];
            chart.draw_series(DashedLineSeries::new(
                vec![(x, 0.0), (x, ymax)],
                6,
                4,
                red.stroke_width(2),
            ))?;
            let right_half = x > x0 + 0.6 * (x1 - x0);
            let pos = if right_half {
                Pos::new(HPos::Right, VPos::Top)
            } else {
                Pos::new(HPos::Left, VPos::Top)
            };
            let dx = (x1 - x0) * 0.008 * if right_half { -1.0 } else { 1.0 };
            chart.draw_series(std::iter::once(Text::new(
                label,
                (x + dx, ymax * 0.97),
                font(TICK_SIZE).color(&red).pos(pos),
            )))?;
        }
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// Maps

/// A raster for a map: south-west origin, rows going north, row-major values.
pub(crate) struct Raster {
    pub origin_x: f64,
    pub origin_y: f64,
    pub cell_m: f64,
    pub nx: usize,
    pub ny: usize,
    pub values: Vec<Option<f64>>,
}

impl Raster {
    /// Averages blocks of cells so that neither side exceeds `max_cells` (keeps the SVG small).
    pub(crate) fn downsampled(&self, max_cells: usize) -> Raster {
        let k = self.nx.max(self.ny).div_ceil(max_cells.max(1)).max(1);
        if k == 1 {
            return Raster {
                values: self.values.clone(),
                ..*self
            };
        }
        let (nx, ny) = (self.nx.div_ceil(k), self.ny.div_ceil(k));
        let mut sum = vec![0.0; nx * ny];
        let mut cnt = vec![0u32; nx * ny];
        for j in 0..self.ny {
            for i in 0..self.nx {
                if let Some(Some(v)) = self.values.get(j * self.nx + i)
                    && v.is_finite()
                {
                    let c = (j / k) * nx + i / k;
                    sum[c] += v;
                    cnt[c] += 1;
                }
            }
        }
        Raster {
            origin_x: self.origin_x,
            origin_y: self.origin_y,
            cell_m: self.cell_m * k as f64,
            nx,
            ny,
            values: sum
                .iter()
                .zip(&cnt)
                .map(|(s, &c)| (c > 0).then(|| s / c as f64))
                .collect(),
        }
    }
}

impl Clone for Raster {
    fn clone(&self) -> Self {
        Raster {
            values: self.values.clone(),
            ..*self
        }
    }
}

/// How values map to colours.
#[derive(Clone, Copy)]
pub(crate) enum Scale {
    /// Viridis from `min` to `max`.
    Sequential { min: f64, max: f64 },
    /// Blue – white – red, symmetric: `-limit` → blue, 0 → white, `+limit` → red.
    Diverging { limit: f64 },
}

impl Scale {
    fn range(self) -> (f64, f64) {
        match self {
            Scale::Sequential { min, max } => (min, max),
            Scale::Diverging { limit } => (-limit, limit),
        }
    }

    fn color(self, v: f64) -> RGBColor {
        const VIRIDIS: [(u8, u8, u8); 6] = [
            (68, 1, 84),
            (65, 68, 135),
            (42, 120, 142),
            (34, 168, 132),
            (122, 209, 81),
            (253, 231, 37),
        ];
        const DIVERGING: [(u8, u8, u8); 5] = [
            (33, 102, 172),
            (146, 197, 222),
            (247, 247, 247),
            (244, 165, 130),
            (178, 24, 43),
        ];
        let (lo, hi) = self.range();
        let t = if hi > lo {
            ((v - lo) / (hi - lo)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let stops: &[(u8, u8, u8)] = match self {
            Scale::Sequential { .. } => &VIRIDIS,
            Scale::Diverging { .. } => &DIVERGING,
        };
        let f = t * (stops.len() - 1) as f64;
        let i = (f.floor() as usize).min(stops.len() - 2);
        let u = f - i as f64;
        let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * u).round() as u8;
        let (a, b) = (stops[i], stops[i + 1]);
        RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
    }
}

/// One or more maps side by side with one shared colour bar (values in display units).
pub(crate) fn heatmaps(
    id: &str,
    title: &str,
    panels: &[(String, Raster)],
    scale: Scale,
    bar_desc: &str,
) -> String {
    let k = panels.len().max(1) as u32;
    let bar_w = 120u32;
    let panel_w = (WIDTH - bar_w) / k;
    // Plot area inside each panel, px: the label areas and margins are fixed below.
    let (yl, xl, m) = (84u32, 50u32, 10u32);
    let pw = panel_w.saturating_sub(yl + 2 * m).max(50);
    // Largest extent ratio decides the height; every panel gets an equal-scale frame.
    let ratio = panels
        .iter()
        .map(|(_, r)| r.ny as f64 / r.nx.max(1) as f64)
        .fold(0.0f64, f64::max)
        .clamp(0.25, 1.6);
    let ph = (pw as f64 * ratio).round() as u32;
    let panel_title_h = if k > 1 { 30 } else { 0 };
    let h = ph + xl + 2 * m + 44 + panel_title_h;
    svg(id, title, WIDTH, h, |root| {
        let area = titled(root, title)?;
        let (maps, bar) = area.split_horizontally(WIDTH - bar_w);
        let cells = maps.split_evenly((1, k as usize));
        for ((name, r), cell) in panels.iter().zip(cells.iter()) {
            let cell = if k > 1 {
                cell.titled(name, font(DESC_SIZE))?
            } else {
                cell.clone()
            };
            // Equal scale: the frame covers the grid, widened in the short direction.
            let (gw, gh) = (r.nx as f64 * r.cell_m, r.ny as f64 * r.cell_m);
            let (fw, fh) = if gh / gw > ph as f64 / pw as f64 {
                (gh * pw as f64 / ph as f64, gh)
            } else {
                (gw, gw * ph as f64 / pw as f64)
            };
            let cx = r.origin_x + gw / 2.0;
            let cy = r.origin_y + gh / 2.0;
            let mut chart = ChartBuilder::on(&cell)
                .margin(m)
                .x_label_area_size(xl)
                .y_label_area_size(yl)
                .build_cartesian_2d(cx - fw / 2.0..cx + fw / 2.0, cy - fh / 2.0..cy + fh / 2.0)?;
            let fmt = |v: &f64| format!("{v:.0}");
            mesh!(chart)
                .disable_mesh()
                .x_labels(match k {
                    1 => 7,
                    2 => 4,
                    // Three panels leave room for two six-digit eastings.
                    _ => 2,
                })
                .y_labels(6)
                .x_label_formatter(&fmt)
                .y_label_formatter(&fmt)
                .x_desc("easting (m)")
                .y_desc("northing (m)")
                .draw()?;
            chart.draw_series(
                (0..r.ny)
                    .flat_map(|j| (0..r.nx).map(move |i| (i, j)))
                    .filter_map(|(i, j)| {
                        let v = r.values.get(j * r.nx + i).copied().flatten()?;
                        if !v.is_finite() {
                            return None;
                        }
                        let x = r.origin_x + i as f64 * r.cell_m;
                        let y = r.origin_y + j as f64 * r.cell_m;
                        Some(Rectangle::new(
                            [(x, y), (x + r.cell_m, y + r.cell_m)],
                            scale.color(v).filled(),
                        ))
                    }),
            )?;
            // Grid outline.
            let (x0, y0) = (r.origin_x, r.origin_y);
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x0, y0), (x0 + gw, y0 + gh)],
                RGBColor(120, 120, 120).stroke_width(1),
            )))?;
        }
        // Colour bar.
        let (lo, hi) = scale.range();
        let bar = bar.margin((panel_title_h + m + 10) as i32, (xl + m) as i32, 10, 48);
        // Room under the title for the top tick label.
        let bar = bar.titled(bar_desc, font(TICK_SIZE))?.margin(12, 0, 0, 0);
        let mut cb = ChartBuilder::on(&bar)
            .y_label_area_size(0)
            .right_y_label_area_size(40)
            .build_cartesian_2d(0.0..1.0, lo..hi)?;
        let dc = decimals(lo, hi);
        let cfmt = |v: &f64| tick(*v, dc);
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(6)
            .y_label_formatter(&cfmt)
            .label_style(font(TICK_SIZE))
            .axis_style(RGBColor(90, 90, 90))
            .draw()?;
        let steps = 64;
        cb.draw_series((0..steps).map(|s| {
            let a = lo + (hi - lo) * s as f64 / steps as f64;
            let b = lo + (hi - lo) * (s + 1) as f64 / steps as f64;
            Rectangle::new([(0.0, a), (1.0, b)], scale.color((a + b) / 2.0).filled())
        }))?;
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// Residual vectors

/// One set of residual vectors: name, colour index, (id, control easting, northing, d north, d east) in m.
pub(crate) struct Vectors {
    pub name: String,
    pub color: usize,
    pub items: Vec<(String, f64, f64, f64, f64)>,
}

/// Horizontal residual vectors on a plan view, all sets at one exaggeration, with a scale bar.
pub(crate) fn residual_vectors(id: &str, title: &str, sets: &[Vectors]) -> String {
    let all: Vec<&(String, f64, f64, f64, f64)> =
        sets.iter().flat_map(|s| s.items.iter()).collect();
    let (xa, xb) = span(all.iter().map(|p| p.1), false, 0.0);
    let (ya, yb) = span(all.iter().map(|p| p.2), false, 0.0);
    let max_res = all
        .iter()
        .map(|p| p.3.hypot(p.4))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let (h, yl, xl, m) = (640u32, 92u32, 52u32, 14u32);
    let pw = (WIDTH - yl - 2 * m) as f64;
    let ph = (h - 44 - xl - 2 * m) as f64;
    let extent = (xb - xa).max(yb - ya).max(1.0);
    // The longest arrow is 18 % of the extent; the exaggeration is a round number.
    let exaggeration = if max_res > 0.0 {
        nice(0.18 * extent / max_res)
    } else {
        1.0
    };
    let half = extent * 0.5 + max_res * exaggeration + extent * 0.08;
    let (cx, cy) = ((xa + xb) / 2.0, (ya + yb) / 2.0);
    // Equal scale in x and y.
    let (hw, hh) = if pw >= ph {
        (half * pw / ph, half)
    } else {
        (half, half * ph / pw)
    };
    let label_ids = all.len() <= 40;
    svg(id, title, WIDTH, h, |root| {
        let area = titled(root, title)?;
        let mut chart = ChartBuilder::on(&area)
            .margin(m)
            .x_label_area_size(xl)
            .y_label_area_size(yl)
            .build_cartesian_2d(cx - hw..cx + hw, cy - hh..cy + hh)?;
        let fmt = |v: &f64| format!("{v:.0}");
        mesh!(chart)
            .x_label_formatter(&fmt)
            .y_label_formatter(&fmt)
            .x_labels(7)
            .y_labels(7)
            .x_desc("easting (m)")
            .y_desc("northing (m)")
            .draw()?;
        let head = |x0: f64, y0: f64, dx: f64, dy: f64| -> Vec<(f64, f64)> {
            let len = dx.hypot(dy);
            let hl = (len * 0.35).min(extent * 0.035);
            let (ux, uy) = (dx / len, dy / len);
            let (tx, ty) = (x0 + dx, y0 + dy);
            vec![
                (tx, ty),
                (tx - ux * hl - uy * hl * 0.45, ty - uy * hl + ux * hl * 0.45),
                (tx - ux * hl + uy * hl * 0.45, ty - uy * hl - ux * hl * 0.45),
            ]
        };
        for s in sets {
            let color = PALETTE[s.color % PALETTE.len()];
            let style = color.stroke_width(3);
            let arrows: Vec<_> = s
                .items
                .iter()
                .filter(|p| p.3.hypot(p.4) > 0.0 && p.3.is_finite() && p.4.is_finite())
                .map(|p| (p.1, p.2, p.4 * exaggeration, p.3 * exaggeration))
                .collect();
            chart
                .draw_series(arrows.iter().map(|&(x, y, dx, dy)| {
                    PathElement::new(vec![(x, y), (x + dx, y + dy)], style)
                }))?
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], style));
            chart.draw_series(
                arrows
                    .iter()
                    .map(|&(x, y, dx, dy)| Polygon::new(head(x, y, dx, dy), color.filled())),
            )?;
        }
        // Control points and their ids (from the first set that has them).
        let mut seen = std::collections::BTreeSet::new();
        let points: Vec<_> = all.iter().filter(|p| seen.insert(p.0.clone())).collect();
        chart.draw_series(
            points
                .iter()
                .map(|p| Circle::new((p.1, p.2), 3, BLACK.filled())),
        )?;
        if label_ids {
            chart.draw_series(points.iter().map(|p| {
                Text::new(
                    p.0.clone(),
                    (p.1 + extent * 0.012, p.2 - extent * 0.012),
                    font(TICK_SIZE).pos(Pos::new(HPos::Left, VPos::Top)),
                )
            }))?;
        }
        // Scale bar: a round residual length, bottom left.
        if max_res > 0.0 {
            let bar_m = nice(max_res / 2.0);
            let len = bar_m * exaggeration;
            let x0 = cx - hw + hw * 0.06;
            let y0 = cy - hh + hh * 0.08;
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(x0, y0), (x0 + len, y0)],
                BLACK.stroke_width(3),
            )))?;
            chart.draw_series([(x0, y0), (x0 + len, y0)].into_iter().map(|(x, y)| {
                PathElement::new(
                    vec![(x, y - hh * 0.015), (x, y + hh * 0.015)],
                    BLACK.stroke_width(2),
                )
            }))?;
            chart.draw_series(std::iter::once(Text::new(
                format!(
                    "{} residual (vectors ×{})",
                    fmt_len_cm(bar_m),
                    fmt_num(exaggeration)
                ),
                (x0, y0 + hh * 0.03),
                font(TICK_SIZE).pos(Pos::new(HPos::Left, VPos::Bottom)),
            )))?;
        }
        legend!(chart, SeriesLabelPosition::UpperRight);
        Ok(())
    })
}

fn fmt_len_cm(m: f64) -> String {
    let cm = m * 100.0;
    if cm >= 1.0 {
        format!("{} cm", fmt_num(cm))
    } else {
        format!("{} mm", fmt_num(cm * 10.0))
    }
}

fn fmt_num(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        format!("{v:.0}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_numbers() {
        assert_eq!(nice(0.9), 1.0);
        assert_eq!(nice(2.6), 2.0);
        assert_eq!(nice(4.0), 5.0);
        assert_eq!(nice(80.0), 100.0);
        assert_eq!(nice(f64::NAN), 1.0);
    }

    #[test]
    fn tick_decimals() {
        assert_eq!(decimals(0.0, 7.0), 0);
        assert_eq!(decimals(0.0, 360.0), 0);
        assert_eq!(decimals(0.0, 1.2), 1);
        assert_eq!(decimals(4.9, 5.3), 2);
        assert_eq!(tick(-0.001, 1), "0.0");
        assert_eq!(tick(-2.0, 0), "-2");
    }

    #[test]
    fn span_never_degenerate() {
        assert_eq!(span([], false, 0.1), (0.0, 1.0));
        let (a, b) = span([2.0, 2.0], false, 0.1);
        assert!(b > a);
        let (a, b) = span([1.0, 3.0], true, 0.1);
        assert_eq!(a, 0.0);
        assert!(b > 3.0);
    }

    #[test]
    fn downsampling_averages_blocks() {
        let r = Raster {
            origin_x: 0.0,
            origin_y: 0.0,
            cell_m: 1.0,
            nx: 4,
            ny: 2,
            values: vec![
                Some(1.0),
                Some(3.0),
                None,
                Some(5.0),
                Some(1.0),
                Some(3.0),
                None,
                None,
            ],
        };
        let d = r.downsampled(2);
        assert_eq!((d.nx, d.ny, d.cell_m), (2, 1, 2.0));
        assert_eq!(d.values, vec![Some(2.0), Some(5.0)]);
    }

    #[test]
    fn diverging_scale_is_white_at_zero() {
        let s = Scale::Diverging { limit: 1.0 };
        assert_eq!(s.color(0.0), RGBColor(247, 247, 247));
        assert_eq!(s.color(-5.0), RGBColor(33, 102, 172));
    }
}
