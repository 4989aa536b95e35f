//! The scaling charts of `meniscus bench`: `--sweep` (per-pass GPU ms against particle count and against pixel
//! count) and `--mesh` (the extraction's wall time against the thread count, splashsurf beside it): panels side
//! by side, log-scaled x, written as PNG (plotters' bitmap backend, encoded by `image`).

use std::path::Path;

use plotters::prelude::*;

use meniscus::{Error, Result};

/// One panel: its title, axis labels and points (x, [(line, y)]).
pub struct Series<'a> {
    pub title: String,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub points: Vec<(f64, Vec<(String, f64)>)>,
}

const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
];

fn register_font() -> Result<()> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| {
        // MENISCUS_FONT: a TTF file of one's own (a machine without fonts, such as the GPU bundle's).
        let own = std::env::var("MENISCUS_FONT").ok();
        for p in own.as_deref().into_iter().chain(FONT_PATHS.iter().copied()) {
            if let Ok(bytes) = std::fs::read(p) {
                let leaked: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, leaked).is_ok() {
                    return true;
                }
            }
        }
        false
    });
    if ok {
        Ok(())
    } else {
        Err(Error::Invalid(
            "the chart needs a TTF font: apt-get install fonts-dejavu-core, or MENISCUS_FONT=path/to/font.ttf".into(),
        ))
    }
}

fn draw_err<E: std::fmt::Display>(e: E) -> Error {
    Error::Invalid(format!("chart drawing failed: {e}"))
}

/// Draw the panels side by side into `path`.
pub fn write(path: &Path, title: &str, panels: &[Series]) -> Result<()> {
    register_font()?;
    let (w, h) = (720 * panels.len().max(1) as u32, 560u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let root = root.titled(title, ("sans-serif", 22)).map_err(draw_err)?;
        let areas = root.split_evenly((1, panels.len().max(1)));
        for (area, s) in areas.iter().zip(panels) {
            if s.points.is_empty() {
                continue;
            }
            let xs: Vec<f64> = s.points.iter().map(|p| p.0).collect();
            let (x0, x1) = (xs.iter().cloned().fold(f64::INFINITY, f64::min), xs.iter().cloned().fold(0.0, f64::max));
            let ymax = s.points.iter().flat_map(|p| p.1.iter().map(|q| q.1)).fold(0.0, f64::max).max(1e-3) * 1.1;
            let mut chart = ChartBuilder::on(area)
                .caption(&s.title, ("sans-serif", 16))
                .margin(16)
                .x_label_area_size(44)
                .y_label_area_size(64)
                .build_cartesian_2d((x0 * 0.8..x1 * 1.25).log_scale(), 0.0..ymax)
                .map_err(draw_err)?;
            chart
                .configure_mesh()
                .x_desc(s.x_label)
                .y_desc(s.y_label)
                .x_label_formatter(&|x| {
                    if *x >= 1e6 {
                        format!("{:.1}M", x / 1e6)
                    } else if *x >= 1e3 {
                        format!("{:.0}k", x / 1e3)
                    } else {
                        format!("{x:.0}")
                    }
                })
                .draw()
                .map_err(draw_err)?;
            let mut names: Vec<String> = vec![];
            for p in &s.points {
                for (n, _) in &p.1 {
                    if !names.contains(n) {
                        names.push(n.clone());
                    }
                }
            }
            for (k, name) in names.iter().enumerate() {
                let color = Palette99::pick(k).to_rgba();
                let pts: Vec<(f64, f64)> =
                    s.points.iter().filter_map(|p| p.1.iter().find(|q| &q.0 == name).map(|q| (p.0, q.1))).collect();
                let style = if name == "total" { color.stroke_width(3) } else { color.stroke_width(2) };
                chart
                    .draw_series(LineSeries::new(pts.clone(), style))
                    .map_err(draw_err)?
                    .label(name.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3)));
                chart
                    .draw_series(pts.iter().map(|&(x, y)| Circle::new((x, y), 3, color.filled())))
                    .map_err(draw_err)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    let img = image::RgbImage::from_raw(w, h, buf).ok_or_else(|| Error::Invalid("chart buffer size".into()))?;
    meniscus::output::write_atomic(path, meniscus::output::FileKind::Png, |wr| {
        image::DynamicImage::ImageRgb8(img).write_to(wr, image::ImageFormat::Png).map_err(std::io::Error::other)
    })
}
