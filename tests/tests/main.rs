//! Every integration test of the workspace's renderer in one test binary: one link of the engine instead
//! of one per file, and one harness whose threads share out all the tests (a file with a few long
//! tests no longer leaves a core idle while it finishes). Each file below is a module with the same
//! name; run one with `cargo test -p shutter-tests --test integration golden::` (a module path is a
//! name filter).

mod accumulation_optics;
mod auto;
mod coverage_paths;
mod errors;
mod golden;
mod graph;
mod hard_cases;
mod hard_cases_precision;
mod interleaved;
mod oit;
mod outputs;
mod quality_plan;
mod shadows;
mod stochastic;
mod texture_space;
mod transparency;
mod vs_reference;
