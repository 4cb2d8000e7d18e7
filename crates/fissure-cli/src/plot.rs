//! Small line plots written as PNG: log or linear axes, decade ticks, a legend, labels in an 8×8 bitmap font.
//!
//! A plotting library would bring a font stack (system fonts or a TTF in the repository) for the labels; the
//! harness needs a handful of log–log line charts, which this draws directly into an RGB buffer.

use std::path::Path;

/// RGB colour.
pub type Rgb = [u8; 3];

/// Distinct colours for series (Tableau 10).
pub const PALETTE: [Rgb; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
];

/// One line of a plot.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points in data coordinates; non-finite or non-positive (on a log axis) points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: Rgb,
    /// Join the points.
    pub line: bool,
    /// Draw a marker at each point.
    pub markers: bool,
    /// Dashed line.
    pub dashed: bool,
}

impl Series {
    /// A solid line with markers.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, color: Rgb) -> Self {
        Series { name: name.into(), points, color, line: true, markers: true, dashed: false }
    }

    /// A dashed line without markers (reference curves, fronts).
    pub fn dashed(name: impl Into<String>, points: Vec<(f64, f64)>, color: Rgb) -> Self {
        Series { name: name.into(), points, color, line: true, markers: false, dashed: true }
    }
}

/// A chart.
#[derive(Clone, Debug)]
pub struct Plot {
    /// Title, drawn at the top.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Log-scale x.
    pub log_x: bool,
    /// Log-scale y.
    pub log_y: bool,
    /// The lines.
    pub series: Vec<Series>,
}

const W: usize = 900;
const H: usize = 600;
const LEFT: usize = 90;
const RIGHT: usize = 250;
const TOP: usize = 40;
const BOTTOM: usize = 60;

struct Canvas {
    px: Vec<u8>,
}

impl Canvas {
    fn set(&mut self, x: i64, y: i64, c: Rgb) {
        if x >= 0 && y >= 0 && (x as usize) < W && (y as usize) < H {
            let o = 3 * (y as usize * W + x as usize);
            self.px[o..o + 3].copy_from_slice(&c);
        }
    }

    fn rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, c: Rgb) {
        for y in y0..=y1 {
            for x in x0..=x1 {
                self.set(x, y, c);
            }
        }
    }

    /// A line `width` pixels thick; `dash` > 0 draws `dash` pixels on, `dash` off.
    fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: Rgb, width: i64, dash: usize) {
        let n = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for k in 0..=n {
            if dash > 0 && (k / dash) % 2 == 1 {
                continue;
            }
            let t = k as f64 / n as f64;
            let (x, y) = ((x0 + t * (x1 - x0)).round() as i64, (y0 + t * (y1 - y0)).round() as i64);
            self.rect(x - width / 2, y - width / 2, x + (width - 1) / 2, y + (width - 1) / 2, c);
        }
    }

    /// Text at `(x, y)` (top left), `scale` pixels per font pixel; `vertical` writes bottom to top.
    fn text(&mut self, x: i64, y: i64, s: &str, scale: i64, c: Rgb, vertical: bool) {
        for (n, ch) in s.chars().enumerate() {
            let glyph = font8x8::legacy::BASIC_LEGACY[if (ch as u32) < 128 { ch as usize } else { b'?' as usize }];
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits >> col & 1 == 1 {
                        for dy in 0..scale {
                            for dx in 0..scale {
                                let (gx, gy) = (col as i64 * scale + dx, row as i64 * scale + dy);
                                let adv = n as i64 * 8 * scale;
                                if vertical {
                                    self.set(x + gy, y - adv - gx, c);
                                } else {
                                    self.set(x + adv + gx, y + gy, c);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Axis mapping data → pixels.
struct Axis {
    log: bool,
    lo: f64,
    hi: f64,
    p0: f64,
    p1: f64,
}

impl Axis {
    fn fit(values: impl Iterator<Item = f64>, log: bool, p0: f64, p1: f64) -> Axis {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values {
            let v = if log { v.log10() } else { v };
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if !lo.is_finite() {
            (lo, hi) = (0.0, 1.0);
        }
        if log {
            lo = lo.floor();
            hi = hi.ceil().max(lo + 1.0);
        } else {
            let pad = ((hi - lo) * 0.05).max(1e-12);
            lo -= pad;
            hi += pad;
        }
        Axis { log, lo, hi, p0, p1 }
    }

    fn map(&self, v: f64) -> f64 {
        let v = if self.log { v.log10() } else { v };
        self.p0 + (v - self.lo) / (self.hi - self.lo) * (self.p1 - self.p0)
    }

    fn usable(&self, v: f64) -> bool {
        v.is_finite() && (!self.log || v > 0.0)
    }

    /// Tick values and labels.
    fn ticks(&self) -> Vec<(f64, String)> {
        if self.log {
            let span = (self.hi - self.lo) as i64;
            let every = (span / 8 + 1).max(1);
            (self.lo as i64..=self.hi as i64)
                .filter(|e| (e - self.lo as i64) % every == 0)
                .map(|e| (10f64.powi(e as i32), format!("1e{e}")))
                .collect()
        } else {
            let raw = (self.hi - self.lo) / 6.0;
            let mag = 10f64.powf(raw.log10().floor());
            let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
            let mut v = (self.lo / step).ceil() * step;
            let mut out = Vec::new();
            while v <= self.hi + 1e-9 * step {
                out.push((v, format_tick(v)));
                v += step;
            }
            out
        }
    }
}

fn format_tick(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

impl Plot {
    /// A chart with the given labels and no series.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Plot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: true,
            log_y: true,
            series: Vec::new(),
        }
    }

    /// Renders to an RGB buffer of `W × H` pixels.
    fn render(&self) -> Vec<u8> {
        let mut c = Canvas { px: vec![255; W * H * 3] };
        let (x0, x1) = (LEFT as f64, (W - RIGHT) as f64);
        let (y0, y1) = ((H - BOTTOM) as f64, TOP as f64);
        let pts = || self.series.iter().flat_map(|s| s.points.iter().copied());
        let ax =
            Axis::fit(pts().filter(|p| p.0.is_finite() && (!self.log_x || p.0 > 0.0)).map(|p| p.0), self.log_x, x0, x1);
        let ay =
            Axis::fit(pts().filter(|p| p.1.is_finite() && (!self.log_y || p.1 > 0.0)).map(|p| p.1), self.log_y, y0, y1);
        let grid = [225, 225, 225];
        let ink = [30, 30, 30];
        for (v, label) in ax.ticks() {
            let x = ax.map(v);
            c.line((x, y1), (x, y0), grid, 1, 0);
            c.line((x, y0), (x, y0 + 5.0), ink, 1, 0);
            c.text(x as i64 - 4 * label.len() as i64, y0 as i64 + 9, &label, 1, ink, false);
        }
        for (v, label) in ay.ticks() {
            let y = ay.map(v);
            c.line((x0, y), (x1, y), grid, 1, 0);
            c.line((x0 - 5.0, y), (x0, y), ink, 1, 0);
            c.text(x0 as i64 - 9 - 8 * label.len() as i64, y as i64 - 4, &label, 1, ink, false);
        }
        c.line((x0, y0), (x1, y0), ink, 1, 0);
        c.line((x0, y0), (x0, y1), ink, 1, 0);
        c.line((x1, y0), (x1, y1), ink, 1, 0);
        c.line((x0, y1), (x1, y1), ink, 1, 0);
        c.text(LEFT as i64, 12, &self.title, 2, ink, false);
        let xl = self.x_label.len() as i64 * 8;
        c.text(((x0 + x1) / 2.0) as i64 - xl / 2, H as i64 - 24, &self.x_label, 1, ink, false);
        let yl = self.y_label.len() as i64 * 8;
        c.text(12, ((y0 + y1) / 2.0) as i64 + yl / 2, &self.y_label, 1, ink, true);
        for s in &self.series {
            let p: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|(x, y)| ax.usable(*x) && ay.usable(*y))
                .map(|&(x, y)| (ax.map(x), ay.map(y)))
                .collect();
            if s.line {
                for w in p.windows(2) {
                    c.line(w[0], w[1], s.color, 2, if s.dashed { 6 } else { 0 });
                }
            }
            if s.markers {
                for &(x, y) in &p {
                    c.rect(x as i64 - 3, y as i64 - 3, x as i64 + 3, y as i64 + 3, s.color);
                }
            }
        }
        // Legend in the right margin.
        let lx = (W - RIGHT + 14) as i64;
        for (k, s) in self.series.iter().enumerate() {
            let y = TOP as i64 + 6 + 16 * k as i64;
            c.line(
                (lx as f64, y as f64 + 4.0),
                (lx as f64 + 22.0, y as f64 + 4.0),
                s.color,
                2,
                if s.dashed { 4 } else { 0 },
            );
            if s.markers {
                c.rect(lx + 8, y + 1, lx + 14, y + 7, s.color);
            }
            let name: String = s.name.chars().take((RIGHT - 44) / 8).collect();
            c.text(lx + 28, y, &name, 1, ink, false);
        }
        c.px
    }

    /// Writes the chart as a PNG file.
    pub fn write_png(&self, path: &Path) -> std::io::Result<()> {
        let px = self.render();
        let file = std::io::BufWriter::new(std::fs::File::create(path)?);
        let mut enc = png::Encoder::new(file, W as u32, H as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(std::io::Error::other)?;
        w.write_image_data(&px).map_err(std::io::Error::other)?;
        Ok(())
    }
}

/// The Pareto front of `(time, error)` points: those no other point beats in both, sorted by time.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points.iter().copied().filter(|(t, e)| t.is_finite() && e.is_finite()).collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if front.last().is_none_or(|l| q.1 < l.1) {
            front.push(q);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let f = pareto_front(&[(1.0, 5.0), (2.0, 6.0), (2.0, 1.0), (3.0, 0.5), (0.5, 9.0), (4.0, 0.7)]);
        assert_eq!(f, vec![(0.5, 9.0), (1.0, 5.0), (2.0, 1.0), (3.0, 0.5)]);
    }

    #[test]
    fn rendered_plot_has_ink_where_the_series_are() {
        let mut p = Plot::new("t", "x", "y");
        p.series.push(Series::new("a", vec![(1e-3, 1e-6), (1e-1, 1e-2)], PALETTE[0]));
        let px = p.render();
        let coloured = px.chunks(3).filter(|c| c == &PALETTE[0]).count();
        assert!(coloured > 200, "{coloured} pixels of the series colour");
        let dark = px.chunks(3).filter(|c| c[0] < 60 && c[1] < 60 && c[2] < 60).count();
        assert!(dark > 500, "{dark} dark pixels (axes, labels)");
    }
}
