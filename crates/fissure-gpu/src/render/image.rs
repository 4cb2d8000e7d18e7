//! [`Image`]: a read-back frame, and the picture statistics the examples' final checks and the tests use
//! (coverage of the body and the room, luma, distinct colours).

use super::*;

/// An RGBA8 (sRGB) image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width \[px\].
    pub width: u32,
    /// Height \[px\].
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba: Vec<u8>,
}

impl Image {
    /// The pixel at `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = 4 * (y * self.width + x) as usize;
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2], self.rgba[i + 3]]
    }

    /// Fraction of pixels within `tolerance` (per channel) of colour `rgb`.
    pub fn fraction_near(&self, rgb: [u8; 3], tolerance: u8) -> f64 {
        let n = self.rgba.chunks_exact(4).filter(|p| (0..3).all(|c| p[c].abs_diff(rgb[c]) <= tolerance)).count();
        n as f64 / (self.width as f64 * self.height as f64).max(1.0)
    }

    /// Mean and standard deviation of the luma (0..255) over all pixels.
    pub fn luma_stats(&self) -> (f64, f64) {
        let n = (self.width as f64 * self.height as f64).max(1.0);
        let luma = |p: &[u8]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
        let mean = self.rgba.chunks_exact(4).map(luma).sum::<f64>() / n;
        let var = self.rgba.chunks_exact(4).map(|p| (luma(p) - mean).powi(2)).sum::<f64>() / n;
        (mean, var.sqrt())
    }

    /// Number of distinct colours (quantised to 5 bits per channel): a blank frame has one or two.
    pub fn distinct_colors(&self) -> usize {
        let mut seen = vec![false; 1 << 15];
        for p in self.rgba.chunks_exact(4) {
            seen[((p[0] as usize >> 3) << 10) | ((p[1] as usize >> 3) << 5) | (p[2] as usize >> 3)] = true;
        }
        seen.iter().filter(|&&s| s).count()
    }

    /// Fraction of bright, nearly grey pixels (luma > 110, channels within 40 of each other): the lit floor and
    /// walls of a room (the background is dark; bodies are saturated).
    pub fn room_coverage(&self) -> f64 {
        let n = self
            .rgba
            .chunks_exact(4)
            .filter(|p| {
                let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                let luma = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
                luma > 110.0 && hi - lo < 40
            })
            .count();
        n as f64 / (self.width as f64 * self.height as f64).max(1.0)
    }

    /// A frame that shows something: not one flat colour (luma spread ≥ 10, ≥ 50 distinct colours) and at
    /// least `min_body` of the pixels in body colour 0. The error says which statistic failed.
    pub fn check_not_blank(&self, min_body: f64) -> Result<(), String> {
        let (mean, sd) = self.luma_stats();
        let colors = self.distinct_colors();
        let body = self.body_coverage(0);
        if sd < 10.0 || colors < 50 {
            return Err(format!("blank frame: luma {mean:.1} ± {sd:.1}, {colors} distinct colours"));
        }
        if body < min_body {
            return Err(format!(
                "the body covers {:.3} % of the frame, want >= {:.3} %",
                100.0 * body,
                100.0 * min_body
            ));
        }
        Ok(())
    }

    /// Fraction of pixels whose hue is close to body colour `k` of [`PALETTE`] (lit or in shade): the
    /// share of the frame a body of that colour covers.
    pub fn body_coverage(&self, k: usize) -> f64 {
        let c = PALETTE[k % PALETTE.len()].map(|v| v as f64);
        let cn = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let n = self
            .rgba
            .chunks_exact(4)
            .filter(|p| {
                let v = [p[0] as f64, p[1] as f64, p[2] as f64];
                let vn = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                vn > 40.0 && (v[0] * c[0] + v[1] * c[1] + v[2] * c[2]) / (vn * cn) > 0.985
            })
            .count();
        n as f64 / (self.width as f64 * self.height as f64).max(1.0)
    }
}
