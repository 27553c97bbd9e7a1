//! Reports for people: SVG drawings of states ([`drawing`]) and figures of
//! results ([`figures`]). They read results; they compute no numerics of
//! their own. Files are written through [`crate::io::write_atomically`].

pub mod drawing;
pub mod figures;
