//! Reports for people: SVG drawings of states ([`drawing`]), figures of
//! results ([`figures`]) and of a closed-loop deployment
//! ([`deployment_figure`]). They read results; they compute no numerics of
//! their own. Files are written through [`crate::io::write_atomically`].

pub mod deployment_figure;
pub mod drawing;
pub mod figures;
pub mod replay_figure;
