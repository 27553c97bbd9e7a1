//! Reports for people: every SVG figure a command writes. Drawings of
//! states ([`drawing`]), grouped bar charts ([`bar_chart`]), and one module
//! per command's figures: a model-versus-log comparison
//! ([`comparison_figures`]), a closed-loop deployment
//! ([`deployment_figure`]), a replay ([`replay_figure`]), an evaluation
//! ([`evaluation_figure`]), the learning curve of cycles
//! ([`cycles_figure`]) and the experiments ([`experiment_figures`]). They
//! read results; they compute no numerics of their own. Files are written
//! through [`crate::io::write_atomically`].

pub mod bar_chart;
pub mod comparison_figures;
pub mod cycles_figure;
pub mod deployment_figure;
pub mod drawing;
pub mod evaluation_figure;
pub mod experiment_figures;
pub mod replay_figure;
