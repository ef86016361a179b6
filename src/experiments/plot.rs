//! The experiments' figures, each written as PNG and SVG with plotters: line
//! plots of a measure over frames and heat maps of camera-pair matrices.
//! PNG labels use an embedded DejaVu Sans, so no system font is needed.

use std::error::Error;
use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Pixels of every figure.
const SIZE: (u32, u32) = (960, 540);
const FONT: &str = "sans-serif";

/// One line of a line plot.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// One series per resolution, labelled `WxH`, holding the points `point`
/// gives for the rows at that resolution (`None` leaves a row out).
pub fn series_per_resolution<R>(
    resolutions: &[(u32, u32)],
    rows: &[R],
    point: impl Fn(&R, (u32, u32)) -> Option<(f64, f64)>,
) -> Vec<Series> {
    resolutions
        .iter()
        .map(|&(w, h)| Series {
            label: format!("{w}x{h}"),
            points: rows.iter().filter_map(|r| point(r, (w, h))).collect(),
        })
        .collect()
}

/// A line plot: one line per series over a shared x axis.
#[derive(Clone, Debug)]
pub struct LinePlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

/// A square matrix of values in [0, 1] with row and column labels.
#[derive(Clone, Debug)]
pub struct HeatMap {
    pub title: String,
    /// Rows are "from" (a), columns "to" (b).
    pub labels: Vec<String>,
    pub values: Vec<Vec<f64>>,
}

/// Why a figure could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct PlotError {
    pub path: PathBuf,
    pub message: String,
}

type DrawResult = Result<(), Box<dyn Error>>;

fn register_font() {
    static FONT_ONCE: Once = Once::new();
    FONT_ONCE.call_once(|| {
        if plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_err() {
            panic!("the embedded DejaVu Sans is a valid font");
        }
    });
}

/// A figure that can be drawn on any plotters backend.
pub trait Figure {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static;

    /// Writes `stem.png` and `stem.svg`; returns their paths.
    fn write(&self, stem: &Path) -> Result<[PathBuf; 2], PlotError> {
        register_font();
        let (png, svg) = (stem.with_extension("png"), stem.with_extension("svg"));
        let failed = |path: &Path| {
            let path = path.to_path_buf();
            move |e: Box<dyn Error>| PlotError { path, message: e.to_string() }
        };
        let mut pixels = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
            self.draw(&root).and_then(|()| Ok(root.present()?)).map_err(failed(&png))?;
        }
        let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, pixels).expect("buffer holds the figure");
        image.save(&png).map_err(|e| failed(&png)(Box::new(e)))?;
        let mut text = String::new();
        {
            let root = SVGBackend::with_string(&mut text, SIZE).into_drawing_area();
            self.draw(&root).and_then(|()| Ok(root.present()?)).map_err(failed(&svg))?;
        }
        std::fs::write(&svg, text).map_err(|e| failed(&svg)(Box::new(e)))?;
        Ok([png, svg])
    }
}

/// Distinct line colours (Tableau 10).
const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

impl Figure for LinePlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let points = || self.series.iter().flat_map(|s| s.points.iter());
        let (x_lo, x_hi) = points().fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p.0), hi.max(p.0)));
        let y_hi = points().fold(0.0f64, |hi, p| hi.max(p.1));
        let (x_lo, x_hi) = if x_lo < x_hi { (x_lo, x_hi) } else { (x_lo.min(0.0) - 1.0, x_hi.max(0.0) + 1.0) };
        let y_hi = if y_hi > 0.0 { y_hi * 1.08 } else { 1.0 };
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, 22))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x_lo..x_hi, 0.0..y_hi)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()?;
        for (i, s) in self.series.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            chart
                .draw_series(LineSeries::new(s.points.iter().copied(), color.stroke_width(2)))?
                .label(&s.label)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
            // A line needs two points: mark a lone one (a configuration
            // measured at one count only) so that it still shows.
            if let [p] = s.points[..] {
                chart.draw_series(std::iter::once(Circle::new(p, 4, color.filled())))?;
            }
        }
        chart
            .configure_series_labels()
            .label_font((FONT, 15))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
        Ok(())
    }
}

/// White (0) to dark blue (1).
fn heat_color(v: f64) -> RGBColor {
    let t = v.clamp(0.0, 1.0);
    let mix = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    RGBColor(mix(247.0, 8.0), mix(251.0, 48.0), mix(255.0, 107.0))
}

impl Figure for HeatMap {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let n = self.labels.len();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, 22))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(80)
            .build_cartesian_2d(0..n, 0..n)?;
        // Axis labels are drawn at the cells' centres below, not at the ticks.
        chart
            .configure_mesh()
            .disable_mesh()
            .x_label_formatter(&|_| String::new())
            .y_label_formatter(&|_| String::new())
            .x_desc("camera b (tiles both need / tiles a needs)")
            .y_desc("camera a")
            .axis_desc_style((FONT, 17))
            .draw()?;
        let centred = |size| TextStyle::from((FONT, size).into_font()).pos(Pos::new(HPos::Center, VPos::Center));
        // The backend point at the centre of cell (column b, row a); row a counts down from the top.
        let centre = |b: usize, a: usize| {
            let (x0, y0) = chart.backend_coord(&(b, n - a));
            let (x1, y1) = chart.backend_coord(&(b + 1, n - 1 - a));
            ((x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0).abs(), (y1 - y0).abs())
        };
        for (a, row) in self.values.iter().enumerate() {
            for (b, &v) in row.iter().enumerate() {
                chart
                    .plotting_area()
                    .draw(&Rectangle::new([(b, n - 1 - a), (b + 1, n - a)], heat_color(v).filled()))?;
                let text_color = if v > 0.5 { WHITE } else { BLACK };
                let (x, y, _, _) = centre(b, a);
                root.draw_text(&format!("{v:.2}"), &centred(16).color(&text_color), (x, y))?;
            }
        }
        for (i, label) in self.labels.iter().enumerate() {
            // Column labels under the bottom row, row labels left of the first column.
            let (x, y, _, h) = centre(i, n - 1);
            root.draw_text(label, &centred(15), (x, y + h / 2 + 12))?;
            let (x, y, w, _) = centre(0, i);
            root.draw_text(label, &centred(15), (x - w / 2 - 14, y))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_write_valid_png_and_svg() {
        let dir = tempfile::tempdir().unwrap();
        let plot = LinePlot {
            title: "ratio".into(),
            x_label: "frame".into(),
            y_label: "ratio".into(),
            series: vec![Series { label: "a".into(), points: vec![(0.0, 1.0), (1.0, 2.0)] }],
        };
        let [png, svg] = plot.write(&dir.path().join("line")).unwrap();
        assert_eq!(image::open(&png).unwrap().width(), SIZE.0);
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg") && text.contains("ratio"), "{}", &text[..100.min(text.len())]);
        let heat = HeatMap {
            title: "overlap".into(),
            labels: vec!["0".into(), "1".into()],
            values: vec![vec![1.0, 0.25], vec![0.5, 1.0]],
        };
        let [png, svg] = heat.write(&dir.path().join("heat")).unwrap();
        let pixels = image::open(&png).unwrap().to_rgb8();
        // Some cell is the colour of 1.0.
        assert!(pixels.pixels().any(|p| *p == image::Rgb([8, 48, 107])));
        assert!(std::fs::read_to_string(&svg).unwrap().contains("0.25"));
    }
}
