//! The permutation tables `build.rs` generates, checked against `shaders-glsl/permutations.toml` read
//! here on its own: every key struct's `source()` is the permutation whose defines are exactly the
//! declared ones for its axis values, each file has the product of its axes, and the permutations the
//! hand-written list had before the axes still exist under their old names with their old defines.

use std::collections::{BTreeMap, BTreeSet};

use crate::shaders::axes::{Effects, Hull, Shadows, TransparencyPass};
use crate::shaders::{
    self, ExpandComp, ShadeDecoupledComp, ShadeExactComp, ShadeTextureSpaceComp, ShaderSource,
    StochasticFrag, StochasticGeom,
};

const DECLARATION: &str = include_str!("../../shaders-glsl/permutations.toml");

/// The declaration as plain data: per axis, its values with the defines each adds (a bool axis is
/// `false` → none, `true` → its define); per stage file with axes, its axis names.
struct Declared {
    axes: BTreeMap<String, Vec<(String, Vec<String>)>>,
    stages: BTreeMap<String, Vec<String>>,
}

fn declared() -> Declared {
    let doc: toml::Table = DECLARATION.parse().expect("permutations.toml parses");
    let mut axes = BTreeMap::new();
    for a in doc["axis"].as_array().unwrap() {
        let name = a["name"].as_str().unwrap().to_string();
        let values = match a["kind"].as_str().unwrap() {
            "bool" => vec![
                ("false".to_string(), vec![]),
                ("true".to_string(), vec![a["define"].as_str().unwrap().to_string()]),
            ],
            "enum" => a["values"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| {
                    let defines = v.get("defines").and_then(|d| d.as_array()).cloned().unwrap_or_default();
                    let defines = defines.iter().map(|d| d.as_str().unwrap().to_string()).collect();
                    (v["name"].as_str().unwrap().to_string(), defines)
                })
                .collect(),
            other => panic!("kind {other}"),
        };
        axes.insert(name, values);
    }
    let stages = doc["stages"]
        .as_table()
        .unwrap()
        .iter()
        .map(|(file, list)| {
            let list = list.as_array().unwrap().iter().map(|a| a.as_str().unwrap().to_string()).collect();
            (file.clone(), list)
        })
        .collect();
    Declared { axes, stages }
}

impl Declared {
    /// The defines declared for these (axis, value) pairs, in axis order.
    fn defines(&self, pairs: &[(&str, &str)]) -> Vec<String> {
        pairs
            .iter()
            .flat_map(|&(axis, value)| {
                let values = &self.axes[axis];
                let (_, defines) = values.iter().find(|(v, _)| v == value).unwrap_or_else(|| {
                    panic!("axis `{axis}` has no declared value `{value}`");
                });
                defines.clone()
            })
            .collect()
    }

    /// The number of permutations of a file: the product of its axes' value counts.
    fn count(&self, file: &str) -> usize {
        self.stages.get(file).map_or(1, |axes| axes.iter().map(|a| self.axes[a].len()).product())
    }
}

/// `source` is the permutation of `file` for these axis values, with exactly the declared defines.
fn check(declared: &Declared, source: ShaderSource, file: &str, pairs: &[(&str, &str)]) {
    let name = format!("{file} [{}]", source.permutation);
    assert_eq!(source.file, file, "{name}");
    assert_eq!(source.axis_values, pairs, "{name}");
    assert_eq!(source.defines, declared.defines(pairs), "{name}");
    assert!(!source.spirv.is_empty(), "{name}");
}

fn same(a: ShaderSource, b: ShaderSource) -> bool {
    a.file == b.file && a.permutation == b.permutation
}

fn bool_name(b: bool) -> &'static str {
    if b {
        "true"
    } else {
        "false"
    }
}

#[test]
fn stochastic_frag_key_selects_the_declared_defines() {
    let d = declared();
    let mut n = 0;
    for hull in Hull::ALL {
        for instrumented in [false, true] {
            for effects in Effects::ALL {
                for transparency_pass in TransparencyPass::ALL {
                    let key = StochasticFrag { hull, instrumented, effects, transparency_pass };
                    let pairs = [
                        ("hull", hull.name()),
                        ("instrumented", bool_name(instrumented)),
                        ("effects", effects.name()),
                        ("transparency_pass", transparency_pass.name()),
                    ];
                    check(&d, key.source(), "stochastic/stochastic.frag", &pairs);
                    assert!(same(StochasticFrag::SOURCES[n], key.source()));
                    assert_eq!(StochasticFrag::ALL[n], key);
                    n += 1;
                }
            }
        }
    }
    assert_eq!(n, StochasticFrag::ALL.len());
    assert_eq!(n, StochasticFrag::SOURCES.len());
}

/// The shading stages, one file per rate: each key selects its file's declared defines, in order.
#[test]
fn shade_keys_select_the_declared_defines() {
    let d = declared();
    let (mut exact, mut texture_space, mut decoupled) = (0, 0, 0);
    for per_sample in [false, true] {
        for instrumented in [false, true] {
            for effects in Effects::ALL {
                for tints in [false, true] {
                    let key = ShadeTextureSpaceComp { per_sample, instrumented, effects, tints };
                    let pairs = [
                        ("per_sample", bool_name(per_sample)),
                        ("instrumented", bool_name(instrumented)),
                        ("effects", effects.name()),
                        ("tints", bool_name(tints)),
                    ];
                    check(&d, key.source(), "stochastic/shade_texture_space.comp", &pairs);
                    assert!(same(ShadeTextureSpaceComp::SOURCES[texture_space], key.source()));
                    assert_eq!(ShadeTextureSpaceComp::ALL[texture_space], key);
                    texture_space += 1;
                }
                for shadows in Shadows::ALL {
                    for shadow_color in [false, true] {
                        for tints in [false, true] {
                            let key = ShadeExactComp {
                                per_sample,
                                instrumented,
                                effects,
                                shadows,
                                shadow_color,
                                tints,
                            };
                            let pairs = [
                                ("per_sample", bool_name(per_sample)),
                                ("instrumented", bool_name(instrumented)),
                                ("effects", effects.name()),
                                ("shadows", shadows.name()),
                                ("shadow_color", bool_name(shadow_color)),
                                ("tints", bool_name(tints)),
                            ];
                            check(&d, key.source(), "stochastic/shade_exact.comp", &pairs);
                            assert!(same(ShadeExactComp::SOURCES[exact], key.source()));
                            assert_eq!(ShadeExactComp::ALL[exact], key);
                            exact += 1;
                            if per_sample {
                                continue;
                            }
                            let key =
                                ShadeDecoupledComp { instrumented, effects, shadows, shadow_color, tints };
                            check(&d, key.source(), "stochastic/shade_decoupled.comp", &pairs[1..]);
                            assert!(same(ShadeDecoupledComp::SOURCES[decoupled], key.source()));
                            assert_eq!(ShadeDecoupledComp::ALL[decoupled], key);
                            decoupled += 1;
                        }
                    }
                }
            }
        }
    }
    assert_eq!(exact, ShadeExactComp::ALL.len());
    assert_eq!(texture_space, ShadeTextureSpaceComp::ALL.len());
    assert_eq!(decoupled, ShadeDecoupledComp::ALL.len());
}

#[test]
fn stochastic_geom_key_selects_the_declared_defines() {
    let d = declared();
    let mut n = 0;
    for bound_debug in [false, true] {
        for effects in Effects::ALL {
            let key = StochasticGeom { bound_debug, effects };
            let pairs = [("bound_debug", bool_name(bound_debug)), ("effects", effects.name())];
            check(&d, key.source(), "stochastic/stochastic.geom", &pairs);
            assert!(same(StochasticGeom::SOURCES[n], key.source()));
            n += 1;
        }
    }
    assert_eq!(n, StochasticGeom::SOURCES.len());
}

#[test]
fn expand_comp_key_selects_the_declared_defines() {
    let d = declared();
    for (n, effects) in Effects::ALL.into_iter().enumerate() {
        let key = ExpandComp { effects };
        check(&d, key.source(), "stochastic/expand.comp", &[("effects", effects.name())]);
        assert!(same(ExpandComp::SOURCES[n], key.source()));
    }
    assert_eq!(ExpandComp::SOURCES.len(), Effects::ALL.len());
}

#[test]
fn axis_enums_match_the_declaration() {
    let d = declared();
    let names = |v: &[(String, Vec<String>)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&d.axes["hull"]), Hull::ALL.map(|v| v.name()));
    assert_eq!(names(&d.axes["shadows"]), Shadows::ALL.map(|v| v.name()));
    assert_eq!(names(&d.axes["effects"]), Effects::ALL.map(|v| v.name()));
    for e in Effects::ALL {
        assert_eq!(e.defines(), d.defines(&[("effects", e.name())]));
    }
    // The first value is the default: it names no permutation.
    assert_eq!(StochasticFrag::default().source().permutation, "DEFAULT");
    assert!(same(StochasticFrag::default().source(), shaders::STOCHASTIC_STOCHASTIC_FRAG));
}

#[test]
fn each_file_has_the_product_of_its_axes() {
    let d = declared();
    // Every stage file under shaders-glsl/ is listed once, with its declared axes.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders-glsl");
    let mut on_disk = BTreeSet::new();
    let mut dirs = vec![root.clone()];
    while let Some(dir) = dirs.pop() {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("vert" | "geom" | "task" | "mesh" | "frag" | "comp")
            ) {
                on_disk.insert(p.strip_prefix(&root).unwrap().to_string_lossy().replace('\\', "/"));
            }
        }
    }
    let listed: BTreeSet<String> = shaders::FILES.iter().map(|f| f.file.to_string()).collect();
    assert_eq!(listed, on_disk);
    assert_eq!(listed.len(), shaders::FILES.len());

    for f in shaders::FILES {
        let axes: Vec<String> = d.stages.get(f.file).cloned().unwrap_or_default();
        assert_eq!(f.axes, axes, "{}", f.file);
        assert_eq!(f.permutations.len(), d.count(f.file), "{}", f.file);
        let mut seen = BTreeSet::new();
        for p in f.permutations {
            assert_eq!(p.file, f.file);
            let pairs: Vec<&str> = p.axis_values.iter().map(|(a, _)| *a).collect();
            assert_eq!(pairs, f.axes, "{} [{}]", f.file, p.permutation);
            check(&d, *p, f.file, p.axis_values);
            assert!(seen.insert(p.permutation), "{} [{}] twice", f.file, p.permutation);
        }
    }
    assert_eq!(d.count("stochastic/stochastic.frag"), 48); // 3 hulls × 2 instrumented × 4 effects × 2 passes

    // The shading stages: 320 permutations where one shade.comp of every rate had 480 (5 rates × 2
    // instrumented × 4 effects × 3 shadows × 2 colour × 2 tints): texture-space lookups shade nothing.
    assert_eq!(d.count("stochastic/shade_exact.comp"), 192); // 2 rates × 2 × 4 effects × 3 shadows × 2 × 2
    assert_eq!(d.count("stochastic/shade_texture_space.comp"), 32); // 2 rates × 2 × 4 effects × 2 tints
    assert_eq!(d.count("stochastic/shade_decoupled.comp"), 96); // 2 × 4 effects × 3 shadows × 2 × 2
    assert_eq!(d.count("texture_space/atlas.geom"), 4); // 2 shadow receiver × 2 sub-passes
    assert_eq!(d.count("texture_space/atlas.frag"), 24); // 2 instrumented × 3 shadows × 2 colour × 2 sub-passes
    assert_eq!(d.count("stochastic/stochastic.geom"), 8);
    assert_eq!(d.count("stochastic/expand.comp"), 4);
    assert_eq!(d.count("stochastic/clusters.comp"), 4);
    assert_eq!(d.count("stochastic/stochastic.vert"), 1);

    // `ALL` is every permutation of every file, once.
    let total: usize = shaders::FILES.iter().map(|f| f.permutations.len()).sum();
    assert_eq!(shaders::ALL.len(), total);
    let all: BTreeSet<(&str, &str)> = shaders::ALL.iter().map(|s| (s.file, s.permutation)).collect();
    assert_eq!(all.len(), total);
}

/// The permutations the hand-written `permutations.txt` listed before the axes (name, defines), and the
/// constants the techniques use: the same names with the same defines — except the shading axis, which
/// left the coverage stage for `shade.comp` when visibility came first (its per-sample constants
/// there), and `shade.comp`'s exact rates now in `shade_exact.comp` (same suffixes and defines).
#[test]
fn the_former_hand_written_permutations_keep_their_names_and_defines() {
    use shaders::*;
    let former: &[(ShaderSource, &str, &str, &[&str])] = &[
        (STOCHASTIC_SHADE_EXACT_COMP_PER_SAMPLE, "shade_exact.comp", "PER_SAMPLE", &["PER_SAMPLE"]),
        (STOCHASTIC_STOCHASTIC_FRAG_INSTRUMENTED, "stochastic.frag", "INSTRUMENTED", &["INSTRUMENTED"]),
        (
            STOCHASTIC_SHADE_EXACT_COMP_PER_SAMPLE_INSTRUMENTED,
            "shade_exact.comp",
            "PER_SAMPLE_INSTRUMENTED",
            &["PER_SAMPLE", "INSTRUMENTED"],
        ),
        (STOCHASTIC_STOCHASTIC_GEOM_BOUND_DEBUG, "stochastic.geom", "BOUND_DEBUG", &["BOUND_DEBUG"]),
        (STOCHASTIC_STOCHASTIC_GEOM_DEFOCUS, "stochastic.geom", "DEFOCUS", &["NO_MOTION"]),
        (STOCHASTIC_STOCHASTIC_GEOM_MOTION, "stochastic.geom", "MOTION", &["NO_DEFOCUS"]),
        (STOCHASTIC_STOCHASTIC_FRAG_DEFOCUS, "stochastic.frag", "DEFOCUS", &["NO_MOTION"]),
        (STOCHASTIC_STOCHASTIC_FRAG_MOTION, "stochastic.frag", "MOTION", &["NO_DEFOCUS"]),
        (
            STOCHASTIC_SHADE_EXACT_COMP_PER_SAMPLE_DEFOCUS,
            "shade_exact.comp",
            "PER_SAMPLE_DEFOCUS",
            &["PER_SAMPLE", "NO_MOTION"],
        ),
        (
            STOCHASTIC_SHADE_EXACT_COMP_PER_SAMPLE_MOTION,
            "shade_exact.comp",
            "PER_SAMPLE_MOTION",
            &["PER_SAMPLE", "NO_DEFOCUS"],
        ),
        (
            STOCHASTIC_STOCHASTIC_FRAG_INSTRUMENTED_DEFOCUS,
            "stochastic.frag",
            "INSTRUMENTED_DEFOCUS",
            &["INSTRUMENTED", "NO_MOTION"],
        ),
        (
            STOCHASTIC_STOCHASTIC_FRAG_INSTRUMENTED_MOTION,
            "stochastic.frag",
            "INSTRUMENTED_MOTION",
            &["INSTRUMENTED", "NO_DEFOCUS"],
        ),
        (
            STOCHASTIC_SHADE_EXACT_COMP_PER_SAMPLE_INSTRUMENTED_DEFOCUS,
            "shade_exact.comp",
            "PER_SAMPLE_INSTRUMENTED_DEFOCUS",
            &["PER_SAMPLE", "INSTRUMENTED", "NO_MOTION"],
        ),
        (
            STOCHASTIC_SHADE_EXACT_COMP_PER_SAMPLE_INSTRUMENTED_MOTION,
            "shade_exact.comp",
            "PER_SAMPLE_INSTRUMENTED_MOTION",
            &["PER_SAMPLE", "INSTRUMENTED", "NO_DEFOCUS"],
        ),
        (STOCHASTIC_EXPAND_COMP_DEFOCUS, "expand.comp", "DEFOCUS", &["NO_MOTION"]),
        (STOCHASTIC_EXPAND_COMP_MOTION, "expand.comp", "MOTION", &["NO_DEFOCUS"]),
        (STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL, "stochastic.frag", "COMPUTE_HULL", &["COMPUTE_HULL"]),
        (
            STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_DEFOCUS,
            "stochastic.frag",
            "COMPUTE_HULL_DEFOCUS",
            &["COMPUTE_HULL", "NO_MOTION"],
        ),
        (
            STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_MOTION,
            "stochastic.frag",
            "COMPUTE_HULL_MOTION",
            &["COMPUTE_HULL", "NO_DEFOCUS"],
        ),
        (
            STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_INSTRUMENTED,
            "stochastic.frag",
            "COMPUTE_HULL_INSTRUMENTED",
            &["COMPUTE_HULL", "INSTRUMENTED"],
        ),
        (
            STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_INSTRUMENTED_DEFOCUS,
            "stochastic.frag",
            "COMPUTE_HULL_INSTRUMENTED_DEFOCUS",
            &["COMPUTE_HULL", "INSTRUMENTED", "NO_MOTION"],
        ),
        (
            STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_INSTRUMENTED_MOTION,
            "stochastic.frag",
            "COMPUTE_HULL_INSTRUMENTED_MOTION",
            &["COMPUTE_HULL", "INSTRUMENTED", "NO_DEFOCUS"],
        ),
    ];
    assert_eq!(former.len(), 22);
    for &(source, file, permutation, defines) in former {
        assert_eq!(source.file, format!("stochastic/{file}"));
        assert_eq!(source.permutation, permutation);
        assert_eq!(source.defines, defines, "{file} [{permutation}]");
    }
    // Each stage file also had its DEFAULT permutation (no extra defines).
    for f in shaders::FILES {
        let default = f.permutations[0];
        assert_eq!((default.permutation, default.defines), ("DEFAULT", &[][..]), "{}", f.file);
    }
    // Spot checks of the key structs against the old constants.
    let key = StochasticFrag {
        hull: Hull::Compute,
        instrumented: true,
        effects: Effects::Motion,
        transparency_pass: TransparencyPass::Coverage,
    };
    assert!(same(key.source(), STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_INSTRUMENTED_MOTION));
    let key = ShadeExactComp {
        per_sample: true,
        instrumented: true,
        effects: Effects::Motion,
        shadows: Shadows::None,
        shadow_color: false,
        tints: false,
    };
    assert!(same(key.source(), STOCHASTIC_SHADE_EXACT_COMP_PER_SAMPLE_INSTRUMENTED_MOTION));
    let key = StochasticGeom { bound_debug: true, effects: Effects::Both };
    assert!(same(key.source(), STOCHASTIC_STOCHASTIC_GEOM_BOUND_DEBUG));
    assert!(same(ExpandComp { effects: Effects::Defocus }.source(), STOCHASTIC_EXPAND_COMP_DEFOCUS));
}
