//! The text overlay: lines rasterised with the public-domain 8×8 font onto a translucent panel.

/// Lines of text rasterised with the public-domain 8×8 font onto a translucent dark panel.
pub(super) struct TextImage {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) rgba: Vec<u8>,
}

impl TextImage {
    pub(super) fn render(lines: &[String], scale: u32) -> Option<TextImage> {
        let scale = scale.max(1);
        let cols = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32;
        if cols == 0 {
            return None;
        }
        let pad = 4 * scale;
        let (width, height) = (cols * 8 * scale + 2 * pad, lines.len() as u32 * 10 * scale + 2 * pad);
        let mut rgba = [10u8, 12, 18, 170].repeat((width * height) as usize);
        for (row, line) in lines.iter().enumerate() {
            for (col, ch) in line.chars().enumerate() {
                let glyph = font8x8::legacy::BASIC_LEGACY.get(ch as usize).copied().unwrap_or([0; 8]);
                for (gy, bits) in glyph.iter().enumerate() {
                    for gx in 0..8u32 {
                        if bits >> gx & 1 == 0 {
                            continue;
                        }
                        for sy in 0..scale {
                            for sx in 0..scale {
                                let x = pad + (col as u32 * 8 + gx) * scale + sx;
                                let y = pad + (row as u32 * 10 + gy as u32) * scale + sy;
                                let i = 4 * (y * width + x) as usize;
                                rgba[i..i + 4].copy_from_slice(&[235, 238, 245, 255]);
                            }
                        }
                    }
                }
            }
        }
        Some(TextImage { width, height, rgba })
    }
}
