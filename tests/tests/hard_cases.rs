//! The hard-case matrix in CI: every scene of `scenes/hard/` against the reference in every technique
//! and shading rate, with the convergence check of [`shutter::hard_cases`] (an exact column's error
//! must fall with S like the reference's own; an approximation's floor must stay within its limit).
//! Small, so the whole matrix fits CI's time on two cores; `shutter hard-cases --out
//! docs/HARD_CASES.md` runs it at the documented size.

use shutter::hard_cases::{markdown, run_row, HardCase, MatrixSettings, Outcome, COLUMNS};
use shutter_tests::{output_dir, renderer};

/// Sizes of the CI run: the reference's RMSE at such sizes is noisy, but the seeds are fixed, and a
/// bias (an error that stops falling) shows at S₂ = 16 as several times the reference's error.
const MATRIX: MatrixSettings = MatrixSettings {
    width: 48,
    height: 27,
    spp: [4, 16],
    truth_spp: 512,
    seed: 1,
    pictures: Some(concat!(env!("CARGO_MANIFEST_DIR"), "/../target/test-output/hard-cases")),
    // Set by `matrix()` from the test run's cache (scripts/test.sh runs the matrix on two drivers;
    // the second takes the CPU references from the first).
    reference_cache: None,
};

/// [`MATRIX`] with the run's reference cache ([`shutter_tests::render_reference`]), where it has one.
fn matrix() -> MatrixSettings {
    // One short string per test; MatrixSettings holds a `&'static str` (the tools' is a literal).
    let cache = shutter_tests::reference_cache_dir().map(|d| &*Box::leak(d.into_boxed_str()));
    MatrixSettings { reference_cache: cache, ..MATRIX }
}

fn check(name: &str) {
    let case = HardCase::named(name).expect("a hard case");
    let mut r = renderer();
    let m = matrix();
    let row = run_row(&mut r, case, COLUMNS, &m).unwrap_or_else(|e| panic!("{name}: {e:#}"));
    let table = markdown(std::slice::from_ref(&row), &m, COLUMNS, "test");
    println!("{table}");
    let _ = std::fs::write(output_dir().join(format!("hard-case-{name}.md")), &table);
    let measured = row.cells.iter().filter(|(_, o)| matches!(o, Outcome::Measured(_))).count();
    assert!(measured >= 3, "{name}: only {measured} columns rendered the scene:\n{table}");
    let failures = row.failures();
    assert!(failures.is_empty(), "{name}:\n{}\n{table}", failures.join("\n"));
}

macro_rules! hard_case_tests {
    ($($test:ident => $name:literal),* $(,)?) => {
        $(#[test] fn $test() { check($name); })*

        /// Every case of the matrix has its test here.
        #[test]
        fn every_hard_case_has_a_test() {
            let tested = [$($name),*];
            for case in shutter::hard_cases::CASES {
                assert!(tested.contains(&case.name), "no test for hard case `{}`", case.name);
            }
        }
    };
}

hard_case_tests!(
    far_from_origin => "far-from-origin",
    near_far_extreme => "near-far-extreme",
    telephoto => "telephoto",
    wide_179 => "wide-179",
    focus_inside_near => "focus-inside-near",
    through_lens => "through-lens",
    camera_turn_180 => "camera-turn-180",
    camera_roll_180 => "camera-roll-180",
    scale_through_zero => "scale-through-zero",
    tiny_shutter => "tiny-shutter",
    multi_turn => "multi-turn",
    stacked_alpha => "stacked-alpha",
    grazing_light => "grazing-light",
    light_on_surface => "light-on-surface",
    huge_and_tiny => "huge-and-tiny",
    huge_plane => "huge-plane",
    slivers => "slivers",
    hard_shadow => "hard-shadow",
);
