//! The demo's text overlay: lines of text (font8x8) and an optional hue legend rasterised on the CPU into an
//! RGBA image, which the `overlay` pass blends over the frame.

/// Rasterise the overlay lines with the font8x8 glyphs (public domain, 8×8, scaled ×2) on a translucent panel;
/// with a legend, a blue→red hue bar under the text. CPU text + a one-dispatch blend pass is all the demo needs:
/// no font atlas, no extra pipeline state, identical on every driver.
pub fn rasterize(lines: &[String], legend: bool, scale: u32) -> image::RgbaImage {
    let s_ = scale.max(1);
    #[allow(non_snake_case)]
    let S = s_;
    let cols = lines.iter().map(|l| l.chars().count()).max().unwrap_or(1) as u32;
    let w = (cols * 8 * S + 16).min(2048);
    let h = lines.len() as u32 * 10 * S + 16 + if legend { 24 } else { 0 };
    let mut img = image::RgbaImage::from_pixel(w, h, image::Rgba([10, 14, 24, 150]));
    for (row, line) in lines.iter().enumerate() {
        for (col, ch) in line.chars().enumerate() {
            let c = ch as usize;
            let glyph =
                if c < 128 { font8x8::legacy::BASIC_LEGACY[c] } else { font8x8::legacy::BASIC_LEGACY[b'?' as usize] };
            for (gy, bits) in glyph.iter().enumerate() {
                for gx in 0..8 {
                    if bits >> gx & 1 == 1 {
                        for sy in 0..S {
                            for sx in 0..S {
                                let x = 8 + (col as u32 * 8 + gx) * S + sx;
                                let y = 8 + (row as u32 * 10 + gy as u32) * S + sy;
                                if x < w && y < h {
                                    img.put_pixel(x, y, image::Rgba([235, 240, 245, 255]));
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    if legend {
        let y0 = h - 22;
        for x in 8..w.min(408) {
            let t = (x - 8) as f32 / 400.0;
            let hue = 0.62 * (1.0 - t);
            let rgb = hsv(hue, 0.85, 0.95);
            for y in y0..y0 + 14 {
                img.put_pixel(x, y, image::Rgba([rgb[0], rgb[1], rgb[2], 255]));
            }
        }
    }
    img
}

pub fn hsv(h: f32, s: f32, v: f32) -> [u8; 3] {
    let f = |n: f32| {
        let k = (n + h * 6.0) % 6.0;
        v - v * s * (k.min(4.0 - k).clamp(0.0, 1.0))
    };
    [(f(5.0) * 255.0) as u8, (f(3.0) * 255.0) as u8, (f(1.0) * 255.0) as u8]
}
