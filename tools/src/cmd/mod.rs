//! One module per subcommand that has grown past a few lines; `main.rs` parses and dispatches.

pub mod bounds;
pub mod calibrate;
pub mod check;
pub mod compare;
pub mod matrix;
pub mod plan;
pub mod quality;
pub mod render;
