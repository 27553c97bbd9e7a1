//! Grouped bar charts: for each label, one bar per series. The figures of
//! the evaluation ([`super::evaluation_figure`]), of the learning curve
//! ([`super::cycles_figure`]) and of the friction-vs-measurement
//! experiment ([`super::experiment_figures`]) are drawn with it.

use plotters::prelude::*;

use super::drawing::DrawingError;

fn err<E: std::fmt::Debug>(e: E) -> DrawingError {
    DrawingError::new(format!("{e:?}"))
}

/// Grouped bars: for each label, one bar per series (the seed's Fig. 16:
/// average tension per instrumented cable), in `unit`.
pub fn grouped_bars_svg(
    title: &str,
    unit: &str,
    labels: &[String],
    series: &[(&str, Vec<f64>)],
) -> Result<String, DrawingError> {
    const COLOURS: [RGBColor; 4] = [
        RGBColor(150, 150, 150),
        RGBColor(40, 80, 200),
        RGBColor(200, 40, 40),
        RGBColor(40, 150, 60),
    ];
    let top = series
        .iter()
        .flat_map(|(_, v)| v.iter().copied())
        .fold(0.0f64, f64::max)
        * 1.1;
    let groups = labels.len().max(1);
    let width = 1.0 / (series.len() as f64 + 1.0);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..groups as f64, 0.0..top.max(1e-9))
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(groups)
            .x_label_formatter(&|x| {
                let k = x.floor() as usize;
                labels.get(k).cloned().unwrap_or_default()
            })
            .y_desc(unit)
            .draw()
            .map_err(err)?;
        for (j, (name, values)) in series.iter().enumerate() {
            let colour = COLOURS[j % COLOURS.len()];
            chart
                .draw_series(values.iter().enumerate().map(|(k, v)| {
                    let x0 = k as f64 + width * (j as f64 + 0.5);
                    Rectangle::new([(x0, 0.0), (x0 + width, *v)], colour.filled())
                }))
                .map_err(err)?
                .label(*name)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour.filled())
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE)
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}
