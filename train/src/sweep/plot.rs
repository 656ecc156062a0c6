//! The sweep's figures, drawn with `plotters` to PNG and SVG: every point (mean over seeds, the
//! seeds' range as error bars on both axes), the Pareto front highlighted and joined, the
//! default configuration marked, each point named where the name clears the others
//! ([`super::labels`]). The PNG's text uses a font compiled in (Ubuntu Light, from
//! `epaint_default_fonts`), so no system font is needed.

use super::labels::{LabelBox, place_labels};
use super::record::Spread;
use crate::error::TrainError;
use plotters::coord::Shift;
use plotters::prelude::*;
use splatzoo_datasets::DatasetError;
use splatzoo_datasets::files::write_bytes;
use std::path::Path;
use std::sync::OnceLock;

const SIZE: (u32, u32) = (960, 640);
const FONT: &str = "sans-serif";

/// One point of a figure.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotPoint {
    pub label: String,
    pub x: Spread,
    pub y: Spread,
    pub front: bool,
    pub default: bool,
}

/// A figure: quality (y, higher is better) against a cost or a speed (x).
#[derive(Debug, Clone, PartialEq)]
pub struct FrontPlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// Where the legend goes (the corner a front of this kind leaves empty).
    pub legend: SeriesLabelPosition,
    pub points: Vec<PlotPoint>,
}

impl FrontPlot {
    /// Writes `<stem>.png` and `<stem>.svg` (each atomically).
    pub fn write(&self, stem: &Path) -> Result<(), TrainError> {
        let png = stem.with_extension("png");
        let svg = stem.with_extension("svg");
        let fail = |path: &Path, e: String| DatasetError::file(path, format!("cannot draw ({e})"));
        register_font().map_err(|e| fail(&png, e))?;
        let mut pixels = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
            self.draw(root).map_err(|e| fail(&png, e))?;
        }
        let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, pixels).expect("sized buffer");
        let mut bytes = std::io::Cursor::new(Vec::new());
        image
            .write_to(&mut bytes, image::ImageFormat::Png)
            .map_err(|e| fail(&png, e.to_string()))?;
        write_bytes(&png, bytes.get_ref())?;
        let mut text = String::new();
        {
            let root = SVGBackend::with_string(&mut text, SIZE).into_drawing_area();
            self.draw(root).map_err(|e| fail(&svg, e))?;
        }
        write_bytes(&svg, text.as_bytes())?;
        Ok(())
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        let text = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(text)?;
        let (x_range, y_range) = self.ranges();
        let mut chart = ChartBuilder::on(&root)
            .caption(&self.title, (FONT, 24))
            .margin(20)
            .x_label_area_size(48)
            .y_label_area_size(64)
            .build_cartesian_2d(x_range, y_range)
            .map_err(text)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(text)?;
        let grey = RGBColor(150, 150, 150);
        let blue = RGBColor(31, 97, 180);
        let red = RGBColor(200, 40, 40);
        for p in &self.points {
            let colour = if p.front { blue } else { grey };
            let (x, y) = (p.x.mean, p.y.mean);
            if p.y.max > p.y.min {
                chart
                    .draw_series(std::iter::once(ErrorBar::new_vertical(
                        x,
                        p.y.min,
                        y,
                        p.y.max,
                        colour.stroke_width(1),
                        8,
                    )))
                    .map_err(text)?;
            }
            if p.x.max > p.x.min {
                chart
                    .draw_series(std::iter::once(ErrorBar::new_horizontal(
                        y,
                        p.x.min,
                        x,
                        p.x.max,
                        colour.stroke_width(1),
                        8,
                    )))
                    .map_err(text)?;
            }
        }
        let mut front: Vec<(f64, f64)> = self
            .points
            .iter()
            .filter(|p| p.front)
            .map(|p| (p.x.mean, p.y.mean))
            .collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(front, blue.stroke_width(2)))
            .map_err(text)?
            .label("Pareto front")
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(2))
            });
        chart
            .draw_series(
                self.points
                    .iter()
                    .filter(|p| !p.front)
                    .map(|p| Circle::new((p.x.mean, p.y.mean), 5, grey.filled())),
            )
            .map_err(text)?
            .label("dominated")
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, grey.filled()));
        chart
            .draw_series(
                self.points
                    .iter()
                    .filter(|p| p.front)
                    .map(|p| Circle::new((p.x.mean, p.y.mean), 6, blue.filled())),
            )
            .map_err(text)?;
        chart
            .draw_series(
                self.points
                    .iter()
                    .filter(|p| p.default)
                    .map(|p| TriangleMarker::new((p.x.mean, p.y.mean), 11, red.filled())),
            )
            .map_err(text)?
            .label("default")
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 8, red.filled()));
        let font = (FONT, 13).into_font();
        let markers: Vec<(i32, i32)> = self
            .points
            .iter()
            .map(|p| chart.backend_coord(&(p.x.mean, p.y.mean)))
            .collect();
        let sizes = self
            .points
            .iter()
            .map(|p| {
                let (w, h) = root
                    .estimate_text_size(&p.label, &TextStyle::from(font.clone()))
                    .map_err(text)?;
                Ok((w as i32, h as i32))
            })
            .collect::<Result<Vec<_>, String>>()?;
        // The front's names first, then the default's, then the dominated points'.
        let mut order: Vec<usize> = (0..self.points.len()).collect();
        order.sort_by_key(|&i| (!self.points[i].front, !self.points[i].default));
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let area = LabelBox {
            x: xs.start,
            y: ys.start,
            width: xs.end - xs.start,
            height: ys.end - ys.start,
        };
        let offsets = place_labels(&markers, &sizes, &order, area);
        chart
            .draw_series(self.points.iter().zip(offsets).map(|(p, offset)| {
                EmptyElement::at((p.x.mean, p.y.mean))
                    + Text::new(p.label.clone(), offset, font.clone())
            }))
            .map_err(text)?;
        chart
            .configure_series_labels()
            .position(self.legend.clone())
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 16))
            .draw()
            .map_err(text)?;
        root.present().map_err(text)?;
        Ok(())
    }

    /// Both axes over every point's range, with margins (wider on the right and the top, where
    /// the labels go) and a non-empty span.
    fn ranges(&self) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
        let span = |lo: f64, hi: f64, after: f64| {
            let (lo, hi) = if lo.is_finite() && hi.is_finite() {
                (lo, hi)
            } else {
                (0.0, 1.0)
            };
            let pad = (hi - lo).max(hi.abs().max(1e-3) * 0.1);
            (lo - 0.06 * pad)..(hi + after * pad)
        };
        let fold = |f: fn(&PlotPoint) -> (f64, f64)| {
            self.points
                .iter()
                .map(f)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (a, b)| {
                    (lo.min(a), hi.max(b))
                })
        };
        let (x0, x1) = fold(|p| (p.x.min, p.x.max));
        let (y0, y1) = fold(|p| (p.y.min, p.y.max));
        (span(x0, x1, 0.2), span(y0, y1, 0.1))
    }
}

/// Makes the compiled-in font the PNG's `sans-serif` (once per process).
fn register_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(
                FONT,
                FontStyle::Normal,
                epaint_default_fonts::UBUNTU_LIGHT,
            )
            .map_err(|_| "the compiled-in font does not parse".to_owned())
        })
        .clone()
}
