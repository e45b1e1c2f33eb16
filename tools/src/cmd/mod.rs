//! One module per subcommand that has grown past a few lines; `main.rs` parses and dispatches.

pub mod calibrate;
pub mod render;
