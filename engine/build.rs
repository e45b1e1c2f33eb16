//! Compiles every GLSL stage under `shaders-glsl/` to SPIR-V with shaderc (glslang) and embeds it.
//!
//! * Stages are recognised by extension: `.vert .geom .task .mesh .frag .comp`; `.glsl` files are include-only.
//! * `#include "common/x.glsl"` resolves relative to `shaders-glsl/` (and to the including file).
//! * `shaders-glsl/permutations.toml` declares permutation axes once (bool: one define on/off; enum:
//!   named values, each a list of defines, the first the default) and lists each stage file's axes.
//!   Every stage file is compiled for the full product of its axes (one permutation if it has none).
//! * Generates `$OUT_DIR/shaders.rs` (included by `shutter::shaders`): one enum per enum axis in
//!   `axes`, one key struct per stage file with axes (`StochasticFrag { .. }.source()`), one `pub const`
//!   per permutation (file path + suffix of each non-default axis value, in axis order), `FILES` and
//!   `ALL`; so a wrong axis, value or permutation name is a compile error, not a run-time lookup failure.
//! * A malformed permutations.toml (unknown axis, unnamed or duplicate value, missing stage file, ...)
//!   panics naming the file and entry, which fails the build.
//! * Errors are reported as `file:line: message` (glslang's own format) and fail the build.
//! * `cargo:rerun-if-changed` is printed for every file read, includes included.

// Linked for its build script's libraries only: what Debian's shaderc archive lacks (its docs).
extern crate shutter_shaderc_link as _;

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

const DECLARATION: &str = "shaders-glsl/permutations.toml";

/// A malformed permutation declaration is a build error naming the file and the entry.
macro_rules! bad {
    ($($arg:tt)*) => { panic!("{DECLARATION}: {}", format!($($arg)*)) };
}

/// `writeln!` into the generated source.
macro_rules! w {
    ($out:expr, $($arg:tt)*) => { writeln!($out, $($arg)*).unwrap() };
}

/// One value of an axis: `false`/`true` for a bool axis, a named value for an enum axis.
struct Choice {
    /// As written in permutations.toml (`defocus`; `true`/`false` for bool axes).
    name: String,
    /// Rust expression / pattern for it (`axes::Effects::Defocus`, `true`).
    rust: String,
    /// Rust variant name (enum axes only).
    variant: String,
    defines: Vec<String>,
    /// Part of the constant's name; `None` for the default value.
    suffix: Option<String>,
}

struct Axis {
    name: String,
    doc: String,
    /// `Some(enum name)` for enum axes, `None` for bool axes.
    enum_name: Option<String>,
    choices: Vec<Choice>,
}

impl Axis {
    fn rust_type(&self) -> String {
        match &self.enum_name {
            Some(e) => format!("axes::{e}"),
            None => "bool".to_string(),
        }
    }
}

/// One compiled permutation of one stage file.
struct Permutation {
    file: String,
    /// `DEFAULT` or the non-default suffixes joined by `_`.
    name: String,
    ident: String,
    /// (axis index, choice index) per axis of the file, in axis order.
    choices: Vec<(usize, usize)>,
    defines: Vec<String>,
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let root = manifest.join("../shaders-glsl").canonicalize().expect("shaders-glsl/ exists");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    println!("cargo:rerun-if-changed={}", root.display());
    // SHUTTER_SHADER_DEBUG_INFO=1 keeps each module's source text and line table (for a shader
    // debugger such as RenderDoc, or validation messages that name a line).
    println!("cargo:rerun-if-env-changed=SHUTTER_SHADER_DEBUG_INFO");
    let debug_info = std::env::var("SHUTTER_SHADER_DEBUG_INFO").is_ok_and(|v| v == "1");

    let mut stages = Vec::new();
    collect(&root, &root, &mut stages);
    stages.sort();

    if root.join("permutations.txt").exists() {
        bad!("shaders-glsl/permutations.txt is no longer read: declare its permutations as axes here");
    }
    let decl_path = root.join("permutations.toml");
    println!("cargo:rerun-if-changed={}", decl_path.display());
    let text = std::fs::read_to_string(&decl_path).unwrap_or_else(|e| bad!("cannot read: {e}"));
    let (axes, stage_axes) = parse_declaration(&text, &stages);
    let perms = permutations(&axes, &stage_axes, &stages);

    // Permutations compile on every core (a compiler per worker: shaderc's is not shared between
    // threads); each SPIR-V depends on its own permutation only, so the bytes are those of one thread,
    // and the generated constants are written in permutation order afterwards.
    let resolved: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());
    let next = AtomicUsize::new(0);
    let results: Vec<Mutex<Option<Compiled>>> = perms.iter().map(|_| Mutex::new(None)).collect();
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get()).min(perms.len().max(1));
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                let compiler = shaderc::Compiler::new().expect("shaderc compiler");
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(p) = perms.get(i) else { break };
                    *results[i].lock().unwrap() = Some(compile(&compiler, &root, p, debug_info, &resolved));
                }
            });
        }
    });
    let mut consts = String::new();
    let mut errors = String::new();
    for (p, result) in perms.iter().zip(results) {
        let (_, _, stage_rs) = stage_of(&root.join(&p.file));
        match result.into_inner().unwrap().expect("every permutation was compiled") {
            Ok(spirv) => {
                let spv_name = format!("{}.spv", p.ident);
                std::fs::write(out_dir.join(&spv_name), spirv).unwrap();
                write_const(&mut consts, p, &axes, stage_rs, &spv_name);
            }
            Err(e) => errors.push_str(&e),
        }
    }
    let resolved = resolved.into_inner().unwrap();
    for p in resolved.iter() {
        println!("cargo:rerun-if-changed={}", p.display());
    }
    if !errors.is_empty() {
        panic!("GLSL compilation failed:\n{errors}");
    }

    let mut generated = String::new();
    w!(
        generated,
        "// @generated by engine/build.rs from shaders-glsl/ and its permutations.toml. Do not edit."
    );
    write_axes(&mut generated, &axes);
    for (file, axis_ids) in &stage_axes {
        write_key_struct(&mut generated, file, axis_ids, &axes, &perms);
    }
    generated.push_str(&consts);
    write_tables(&mut generated, &stages, &stage_axes, &axes, &perms);
    std::fs::write(out_dir.join("shaders.rs"), generated).unwrap();
}

fn collect(root: &Path, dir: &Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            println!("cargo:rerun-if-changed={}", p.display());
            collect(root, &p, out);
        } else if matches!(
            p.extension().and_then(|e| e.to_str()),
            Some("vert" | "geom" | "task" | "mesh" | "frag" | "comp")
        ) {
            out.push(p.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/"));
        }
    }
}

fn stage_of(path: &Path) -> (shaderc::ShaderKind, &'static str, &'static str) {
    match path.extension().unwrap().to_str().unwrap() {
        "vert" => (shaderc::ShaderKind::Vertex, "STAGE_VERTEX", "Vertex"),
        "geom" => (shaderc::ShaderKind::Geometry, "STAGE_GEOMETRY", "Geometry"),
        "task" => (shaderc::ShaderKind::Task, "STAGE_TASK", "Task"),
        "mesh" => (shaderc::ShaderKind::Mesh, "STAGE_MESH", "Mesh"),
        "frag" => (shaderc::ShaderKind::Fragment, "STAGE_FRAGMENT", "Fragment"),
        "comp" => (shaderc::ShaderKind::Compute, "STAGE_COMPUTE", "Compute"),
        _ => unreachable!(),
    }
}

// ---------------------------------------------------------------------------------------------------
// permutations.toml

/// Parses and checks the declaration: the axes in declaration order, and per stage file with axes the
/// indices of its axes (in declaration order).
fn parse_declaration(text: &str, stages: &[String]) -> (Vec<Axis>, BTreeMap<String, Vec<usize>>) {
    let doc: toml::Table = text.parse().unwrap_or_else(|e| bad!("{e}"));
    check_keys(&doc, &["axis", "stages"], "the top level");

    let mut axes: Vec<Axis> = Vec::new();
    let axis_tables = match doc.get("axis") {
        None => Vec::new(),
        Some(toml::Value::Array(a)) => a.clone(),
        Some(_) => bad!("`axis` must be an array of tables (`[[axis]]`)"),
    };
    for (i, t) in axis_tables.iter().enumerate() {
        let t = t.as_table().unwrap_or_else(|| bad!("[[axis]] #{}: not a table", i + 1));
        let name = string(t, "name", &format!("[[axis]] #{}", i + 1));
        let ctx = format!("axis `{name}`");
        check_snake(&name, &ctx);
        if axes.iter().any(|a| a.name == name) {
            bad!("{ctx}: declared twice");
        }
        let doc_line = t.get("doc").map(|_| string(t, "doc", &ctx)).unwrap_or_default();
        let kind = string(t, "kind", &ctx);
        let axis = match kind.as_str() {
            "bool" => {
                check_keys(t, &["name", "kind", "doc", "define", "suffix"], &ctx);
                let define = string(t, "define", &ctx);
                check_define(&define, &ctx);
                let suffix = match t.get("suffix") {
                    Some(_) => string(t, "suffix", &ctx),
                    None => name.to_ascii_uppercase(),
                };
                check_suffix(&suffix, &ctx);
                let choice = |b: bool, defines: Vec<String>, suffix: Option<String>| Choice {
                    name: b.to_string(),
                    rust: b.to_string(),
                    variant: String::new(),
                    defines,
                    suffix,
                };
                Axis {
                    name,
                    doc: doc_line,
                    enum_name: None,
                    choices: vec![choice(false, vec![], None), choice(true, vec![define], Some(suffix))],
                }
            }
            "enum" => {
                check_keys(t, &["name", "kind", "doc", "values"], &ctx);
                let enum_name = camel(&name);
                let values = match t.get("values") {
                    Some(toml::Value::Array(v)) => v,
                    _ => bad!("{ctx}: an enum axis needs `values = [{{ name = \"..\" }}, ...]`"),
                };
                if values.len() < 2 {
                    bad!("{ctx}: an enum axis needs at least two values");
                }
                let mut choices: Vec<Choice> = Vec::new();
                for (j, v) in values.iter().enumerate() {
                    let vctx = format!("{ctx}, value #{}", j + 1);
                    let v = v.as_table().unwrap_or_else(|| bad!("{vctx}: not a table `{{ name = \"..\" }}`"));
                    let vname = string(v, "name", &vctx);
                    let vctx = format!("{ctx}, value `{vname}`");
                    check_keys(v, &["name", "defines", "suffix"], &vctx);
                    check_snake(&vname, &vctx);
                    let variant = camel(&vname);
                    if choices.iter().any(|c| c.name == vname || c.variant == variant) {
                        bad!("{vctx}: declared twice (or two values with the Rust name `{variant}`)");
                    }
                    let defines = match v.get("defines") {
                        None => Vec::new(),
                        Some(toml::Value::Array(d)) => d
                            .iter()
                            .map(|d| {
                                let d = d.as_str().unwrap_or_else(|| bad!("{vctx}: defines must be strings"));
                                check_define(d, &vctx);
                                d.to_string()
                            })
                            .collect(),
                        Some(_) => bad!("{vctx}: `defines` must be an array of strings"),
                    };
                    let suffix = match v.get("suffix") {
                        Some(_) => string(v, "suffix", &vctx),
                        None => vname.to_ascii_uppercase(),
                    };
                    check_suffix(&suffix, &vctx);
                    choices.push(Choice {
                        rust: format!("axes::{enum_name}::{variant}"),
                        name: vname,
                        variant,
                        defines,
                        suffix: (j > 0).then_some(suffix),
                    });
                }
                Axis { name, doc: doc_line, enum_name: Some(enum_name), choices }
            }
            other => bad!("{ctx}: kind `{other}` is neither \"bool\" nor \"enum\""),
        };
        for c in &axis.choices {
            let names: Vec<&str> = c.defines.iter().map(|d| define_name(d)).collect();
            if names.iter().collect::<BTreeSet<_>>().len() != names.len() {
                bad!("{ctx}, value `{}`: a define is listed twice", c.name);
            }
        }
        if let Some(e) = &axis.enum_name {
            if axes.iter().any(|a| a.enum_name.as_ref() == Some(e)) {
                bad!("{ctx}: two axes with the Rust name `{e}`");
            }
        }
        axes.push(axis);
    }

    let mut stage_axes = BTreeMap::new();
    let stage_table = match doc.get("stages") {
        None => toml::Table::new(),
        Some(toml::Value::Table(t)) => t.clone(),
        Some(_) => bad!("`stages` must be a table (`[stages]`)"),
    };
    let mut key_structs: BTreeMap<String, String> = BTreeMap::new();
    for (file, list) in &stage_table {
        let ctx = format!("[stages] `{file}`");
        if !stages.contains(file) {
            bad!("{ctx}: no stage file `{file}` under shaders-glsl/ (stage files: {})", stages.join(", "));
        }
        let list = list.as_array().unwrap_or_else(|| bad!("{ctx}: must be an array of axis names"));
        let mut ids: Vec<usize> = Vec::new();
        for a in list {
            let a = a.as_str().unwrap_or_else(|| bad!("{ctx}: axis names must be strings"));
            let Some(id) = axes.iter().position(|x| x.name == a) else {
                let known: Vec<&str> = axes.iter().map(|x| x.name.as_str()).collect();
                bad!("{ctx}: unknown axis `{a}` (declared axes: {})", known.join(", "))
            };
            if ids.contains(&id) {
                bad!("{ctx}: axis `{a}` listed twice");
            }
            if ids.last().is_some_and(|&last| last > id) {
                let mut sorted = ids.clone();
                sorted.push(id);
                sorted.sort();
                let order: Vec<&str> = sorted.iter().map(|&i| axes[i].name.as_str()).collect();
                bad!(
                    "{ctx}: list the axes in declaration order (they name the constants): [{}]",
                    order.join(", ")
                );
            }
            ids.push(id);
        }
        let key = key_struct_name(file);
        if let Some(other) = key_structs.insert(key.clone(), file.clone()) {
            bad!("{ctx}: `{other}` has the same key struct name `{key}`; rename one file");
        }
        stage_axes.insert(file.clone(), ids);
    }
    for (i, a) in axes.iter().enumerate() {
        if !stage_axes.values().any(|ids| ids.contains(&i)) {
            bad!("axis `{}`: declared but listed by no stage file", a.name);
        }
    }
    (axes, stage_axes)
}

/// Every permutation: per stage file (sorted), the product of its axes, the first axis slowest.
fn permutations(
    axes: &[Axis],
    stage_axes: &BTreeMap<String, Vec<usize>>,
    stages: &[String],
) -> Vec<Permutation> {
    let mut perms = Vec::new();
    let mut idents = BTreeMap::new();
    for file in stages {
        let ids = stage_axes.get(file).cloned().unwrap_or_default();
        let mut combos: Vec<Vec<(usize, usize)>> = vec![Vec::new()];
        for &a in &ids {
            combos = combos
                .into_iter()
                .flat_map(|c| {
                    (0..axes[a].choices.len()).map(move |v| {
                        let mut c = c.clone();
                        c.push((a, v));
                        c
                    })
                })
                .collect();
        }
        for choices in combos {
            let chosen = || choices.iter().map(|&(a, v)| &axes[a].choices[v]);
            let suffixes: Vec<&str> = chosen().filter_map(|c| c.suffix.as_deref()).collect();
            let name = if suffixes.is_empty() { "DEFAULT".to_string() } else { suffixes.join("_") };
            let defines: Vec<String> = chosen().flat_map(|c| c.defines.iter().cloned()).collect();
            let mut seen = BTreeSet::new();
            for d in &defines {
                if !seen.insert(define_name(d)) {
                    bad!("[stages] `{file}`: two of its axes set `{}` (permutation {name})", define_name(d));
                }
            }
            let ident = const_ident(file, &name);
            let values: Vec<String> = choices
                .iter()
                .map(|&(a, v)| format!("{} = {}", axes[a].name, axes[a].choices[v].name))
                .collect();
            let this = format!("`{file}` ({})", values.join(", "));
            if let Some(other) = idents.insert(ident.clone(), this.clone()) {
                bad!("permutations {other} and {this} are both named `{ident}`; change a value's `suffix`");
            }
            perms.push(Permutation { file: file.clone(), name, ident, choices, defines });
        }
    }
    perms
}

fn check_keys(t: &toml::Table, allowed: &[&str], ctx: &str) {
    for k in t.keys() {
        if !allowed.contains(&k.as_str()) {
            bad!("{ctx}: unknown key `{k}` (expected one of: {})", allowed.join(", "));
        }
    }
}

fn string(t: &toml::Table, key: &str, ctx: &str) -> String {
    match t.get(key) {
        Some(toml::Value::String(s)) => s.clone(),
        Some(_) => bad!("{ctx}: `{key}` must be a string"),
        None => bad!("{ctx}: missing `{key}`"),
    }
}

/// Axis and value names become Rust fields and enum variants: lower snake case, not a keyword.
fn check_snake(s: &str, ctx: &str) {
    let ok = s.starts_with(|c: char| c.is_ascii_lowercase())
        && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
    const KEYWORDS: &[&str] = &[
        "as", "async", "await", "box", "break", "const", "continue", "crate", "do", "dyn", "else", "enum",
        "extern", "false", "final", "fn", "for", "gen", "if", "impl", "in", "let", "loop", "macro", "match",
        "mod", "move", "mut", "override", "priv", "pub", "ref", "return", "self", "static", "struct",
        "super", "trait", "true", "try", "type", "typeof", "unsafe", "unsized", "use", "virtual", "where",
        "while", "yield",
    ];
    if !ok || KEYWORDS.contains(&s) {
        bad!("{ctx}: name `{s}` must be lower snake case ([a-z][a-z0-9_]*) and not a Rust keyword");
    }
}

fn check_define(d: &str, ctx: &str) {
    let name = define_name(d);
    let ok = name.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !ok {
        bad!("{ctx}: define `{d}` is not NAME or NAME=VALUE");
    }
    if name.starts_with("STAGE_") {
        bad!("{ctx}: define `{d}`: STAGE_* is set by build.rs from the file's extension");
    }
}

fn check_suffix(s: &str, ctx: &str) {
    let ok = s.starts_with(|c: char| c.is_ascii_uppercase())
        && s.chars().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_');
    if !ok {
        bad!("{ctx}: suffix `{s}` must be upper snake case ([A-Z][A-Z0-9_]*)");
    }
}

fn define_name(d: &str) -> &str {
    d.split_once('=').map_or(d, |(k, _)| k)
}

/// `per_sample` → `PerSample`, `stochastic.frag` → `StochasticFrag`.
fn camel(s: &str) -> String {
    s.split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|p| !p.is_empty())
        .map(|p| {
            let mut c = p.chars();
            let first = c.next().unwrap().to_ascii_uppercase();
            std::iter::once(first).chain(c).collect::<String>()
        })
        .collect()
}

/// `stochastic/stochastic.frag` → `StochasticFrag` (the file name, without its folder).
fn key_struct_name(file: &str) -> String {
    let base = file.rsplit('/').next().unwrap();
    let name = camel(base);
    if !name.starts_with(|c: char| c.is_ascii_alphabetic()) {
        bad!("[stages] `{file}`: the file name must start with a letter (it names the key struct)");
    }
    name
}

/// `forward/forward.frag` + `TEXTURED` → `FORWARD_FORWARD_FRAG_TEXTURED`.
fn const_ident(file: &str, perm: &str) -> String {
    let mut s: String =
        file.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_uppercase() } else { '_' }).collect();
    if perm != "DEFAULT" {
        s.push('_');
        s.push_str(&perm.to_ascii_uppercase());
    }
    s
}

// ---------------------------------------------------------------------------------------------------
// Generated Rust (`$OUT_DIR/shaders.rs`, included in `shutter::shaders`)

fn quoted(items: &[String]) -> String {
    items.iter().map(|s| format!("{s:?}")).collect::<Vec<_>>().join(", ")
}

fn code_list(items: &[String]) -> String {
    if items.is_empty() {
        "no defines".to_string()
    } else {
        items.iter().map(|s| format!("`{s}`")).collect::<Vec<_>>().join(" ")
    }
}

fn write_axes(out: &mut String, axes: &[Axis]) {
    w!(out, "/// The permutation axes declared in `shaders-glsl/permutations.toml`: one enum per enum axis,");
    w!(out, "/// whose first variant is the default (it adds nothing to a permutation's name).");
    w!(out, "/// Bool axes are plain `bool`.");
    w!(out, "pub mod axes {{");
    for a in axes {
        let Some(e) = &a.enum_name else { continue };
        for line in a.doc.lines() {
            w!(out, "    /// {line}\n    ///");
        }
        w!(out, "    /// Axis `{}`; each value and the defines it adds:", a.name);
        for (i, c) in a.choices.iter().enumerate() {
            let default = if i == 0 { " (default)" } else { "" };
            w!(out, "    /// * `{}`{default}: {}", c.name, code_list(&c.defines));
        }
        w!(out, "    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]");
        w!(out, "    pub enum {e} {{");
        for (i, c) in a.choices.iter().enumerate() {
            w!(out, "        /// `{}`: {}.", c.name, code_list(&c.defines));
            if i == 0 {
                w!(out, "        #[default]");
            }
            w!(out, "        {},", c.variant);
        }
        w!(out, "    }}");
        let variants: Vec<String> = a.choices.iter().map(|c| format!("Self::{}", c.variant)).collect();
        w!(out, "    impl {e} {{");
        w!(out, "        /// Every value, the default first.");
        w!(out, "        pub const ALL: [Self; {}] = [{}];", a.choices.len(), variants.join(", "));
        w!(
            out,
            "        /// The value's name in permutations.toml, as in [`super::ShaderSource::axis_values`]."
        );
        w!(out, "        pub const fn name(self) -> &'static str {{");
        w!(out, "            match self {{");
        for c in &a.choices {
            w!(out, "                Self::{} => {:?},", c.variant, c.name);
        }
        w!(out, "            }}\n        }}");
        w!(out, "        /// The defines this value adds to a permutation.");
        w!(out, "        pub const fn defines(self) -> &'static [&'static str] {{");
        w!(out, "            match self {{");
        for c in &a.choices {
            w!(out, "                Self::{} => &[{}],", c.variant, quoted(&c.defines));
        }
        w!(out, "            }}\n        }}\n    }}");
    }
    w!(out, "}}");
}

/// The key struct of one stage file: one field per axis, `source()` an exhaustive match.
fn write_key_struct(out: &mut String, file: &str, axis_ids: &[usize], axes: &[Axis], perms: &[Permutation]) {
    let key = key_struct_name(file);
    let fields: Vec<&str> = axis_ids.iter().map(|&a| axes[a].name.as_str()).collect();
    let mine: Vec<&Permutation> = perms.iter().filter(|p| p.file == file).collect();
    w!(out, "/// Selects a permutation of `shaders-glsl/{file}` by its axes:");
    w!(out, "/// `{key} {{ {} }}.source()`.", fields.join(", "));
    w!(out, "///");
    w!(out, "/// One field per axis, so a wrong axis or value is a compile error. `{key}::default()`, every");
    w!(out, "/// axis at its default, is [`{}`]; [`{key}::ALL`] and", mine[0].ident);
    w!(out, "/// [`{key}::SOURCES`] list all {} permutations.", mine.len());
    w!(out, "#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]");
    w!(out, "pub struct {key} {{");
    for &a in axis_ids {
        let axis = &axes[a];
        match &axis.enum_name {
            Some(e) => w!(out, "    /// Axis `{}`: [`axes::{e}`].", axis.name),
            None => {
                w!(out, "    /// Axis `{}`: {} when true.", axis.name, code_list(&axis.choices[1].defines));
                for line in axis.doc.lines() {
                    w!(out, "    /// {line}");
                }
            }
        }
        w!(out, "    pub {}: {},", axis.name, axis.rust_type());
    }
    w!(out, "}}");
    w!(out, "impl {key} {{");
    w!(out, "    /// The stage file, under `shaders-glsl/`.");
    w!(out, "    pub const FILE: &'static str = {file:?};");
    w!(out, "    /// Every key, the product of the axes (the first axis slowest), in the order of");
    w!(out, "    /// [`Self::SOURCES`].");
    w!(out, "    pub const ALL: &'static [Self] = &[");
    for p in &mine {
        let f: Vec<String> = p
            .choices
            .iter()
            .map(|&(a, v)| format!("{}: {}", axes[a].name, axes[a].choices[v].rust))
            .collect();
        w!(out, "        Self {{ {} }},", f.join(", "));
    }
    w!(out, "    ];");
    w!(out, "    /// Every permutation of the file, in the order of [`Self::ALL`].");
    w!(out, "    pub const SOURCES: &'static [ShaderSource] = &[");
    for p in &mine {
        w!(out, "        {},", p.ident);
    }
    w!(out, "    ];");
    let scrutinee: Vec<String> = fields.iter().map(|f| format!("self.{f}")).collect();
    w!(out, "    /// The compiled permutation for these axis values.");
    w!(out, "    pub const fn source(self) -> ShaderSource {{");
    w!(out, "        match ({},) {{", scrutinee.join(", "));
    for p in &mine {
        let pat: Vec<&str> = p.choices.iter().map(|&(a, v)| axes[a].choices[v].rust.as_str()).collect();
        w!(out, "            ({},) => {},", pat.join(", "), p.ident);
    }
    w!(out, "        }}\n    }}\n}}");
}

/// A permutation's SPIR-V, or its errors in glslang's words.
type Compiled = Result<Vec<u8>, String>;

/// Compiles one permutation: its SPIR-V, or its errors in glslang's words; `resolved` collects every
/// file it read (for `cargo:rerun-if-changed`). Warnings are build warnings.
fn compile(
    compiler: &shaderc::Compiler,
    root: &Path,
    p: &Permutation,
    debug_info: bool,
    resolved: &Mutex<BTreeSet<PathBuf>>,
) -> Compiled {
    let path = root.join(&p.file);
    resolved.lock().unwrap().insert(path.clone());
    let source = std::fs::read_to_string(&path).expect("read shader");
    let (kind, stage_define, _) = stage_of(&path);
    let mut opts = shaderc::CompileOptions::new().unwrap();
    // SPIR-V 1.5 (Vulkan 1.2): SPIR-V 1.6 compute would require maintenance4.
    opts.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    opts.set_target_spirv(shaderc::SpirvVersion::V1_5);
    // glslang keeps the optimizer from stripping names only when it emits debug info, and the
    // layout tests (gpu/layout_tests.rs) match every block and member by its `OpName`/`OpMemberName`.
    // So debug info is always generated, and `strip_source_and_lines` then drops the source text and
    // line table (half of every module: 52 MB of SPIR-V in all, 27 MB without) unless
    // SHUTTER_SHADER_DEBUG_INFO=1 asks to keep them. Debug instructions change no code, so the
    // images are the same either way (golden hashes).
    opts.set_generate_debug_info();
    opts.set_optimization_level(shaderc::OptimizationLevel::Performance);
    opts.set_warnings_as_errors();
    opts.add_macro_definition(stage_define, Some("1"));
    for d in &p.defines {
        match d.split_once('=') {
            Some((k, v)) => opts.add_macro_definition(k, Some(v)),
            None => opts.add_macro_definition(d, None),
        }
    }
    let root_c = root.to_path_buf();
    opts.set_include_callback(move |name, ty, from, _depth| {
        let candidates = match ty {
            shaderc::IncludeType::Relative => {
                let base = Path::new(from).parent().unwrap_or(Path::new("")).to_path_buf();
                vec![base.join(name), root_c.join(name)]
            }
            shaderc::IncludeType::Standard => vec![root_c.join(name)],
        };
        for c in candidates {
            if let Ok(content) = std::fs::read_to_string(&c) {
                let c = c.canonicalize().unwrap_or(c);
                resolved.lock().unwrap().insert(c.clone());
                return Ok(shaderc::ResolvedInclude { resolved_name: c.display().to_string(), content });
            }
        }
        Err(format!("cannot find include `{name}` (searched relative to `{from}` and shaders-glsl/)"))
    });
    match compiler.compile_into_spirv(&source, kind, &path.display().to_string(), "main", Some(&opts)) {
        Ok(art) => {
            if art.get_num_warnings() > 0 {
                println!("cargo:warning={}", art.get_warning_messages());
            }
            let words = art.as_binary();
            let words = if debug_info { words.to_vec() } else { strip_source_and_lines(words) };
            Ok(words.iter().flat_map(|w| w.to_le_bytes()).collect())
        }
        Err(e) => Err(format!("{} [{}]:\n{e}\n", p.file, p.name)),
    }
}

/// A SPIR-V module without its source text and line table: `OpSourceContinued`, `OpSource`,
/// `OpSourceExtension`, `OpString`, `OpLine`, `OpNoLine` and `OpModuleProcessed` go; names
/// (`OpName`, `OpMemberName`) and everything else stay, word for word. `OpString` is only an operand
/// of `OpSource` and `OpLine` here (no shader uses debug printf), which this checks.
fn strip_source_and_lines(words: &[u32]) -> Vec<u32> {
    const SOURCE_CONTINUED: u32 = 2;
    const SOURCE: u32 = 3;
    const SOURCE_EXTENSION: u32 = 4;
    const STRING: u32 = 7;
    const LINE: u32 = 8;
    const EXT_INST_IMPORT: u32 = 11;
    const NO_LINE: u32 = 317;
    const MODULE_PROCESSED: u32 = 330;
    const HEADER: usize = 5;
    assert!(words.len() >= HEADER && words[0] == 0x0723_0203, "shaderc returned a SPIR-V module");
    let mut out = words[..HEADER].to_vec();
    let mut at = HEADER;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let opcode = words[at] & 0xffff;
        assert!(count > 0 && at + count <= words.len(), "a well-formed SPIR-V instruction at word {at}");
        let instruction = &words[at..at + count];
        if opcode == EXT_INST_IMPORT {
            let name: Vec<u8> = instruction[2..].iter().flat_map(|w| w.to_le_bytes()).collect();
            assert!(
                !name.starts_with(b"NonSemantic."),
                "a non-semantic instruction set may name an OpString; strip_source_and_lines cannot drop them"
            );
        }
        if !matches!(
            opcode,
            SOURCE_CONTINUED | SOURCE | SOURCE_EXTENSION | STRING | LINE | NO_LINE | MODULE_PROCESSED
        ) {
            out.extend_from_slice(instruction);
        }
        at += count;
    }
    out
}

fn write_const(out: &mut String, p: &Permutation, axes: &[Axis], stage_rs: &str, spv_name: &str) {
    let values: Vec<String> =
        p.choices.iter().map(|&(a, v)| format!("{} = {}", axes[a].name, axes[a].choices[v].name)).collect();
    let pairs: Vec<String> = p
        .choices
        .iter()
        .map(|&(a, v)| format!("({:?}, {:?})", axes[a].name, axes[a].choices[v].name))
        .collect();
    let values = if values.is_empty() { String::new() } else { format!(": {}", values.join(", ")) };
    w!(out, "/// `shaders-glsl/{}`, permutation `{}`{values}.", p.file, p.name);
    w!(out, "pub const {}: ShaderSource = ShaderSource {{", p.ident);
    w!(out, "    file: {:?},", p.file);
    w!(out, "    permutation: {:?},", p.name);
    w!(out, "    stage: ShaderStage::{stage_rs},");
    w!(out, "    defines: &[{}],", quoted(&p.defines));
    w!(out, "    axis_values: &[{}],", pairs.join(", "));
    w!(out, "    spirv: include_bytes!(concat!(env!(\"OUT_DIR\"), \"/{spv_name}\")),");
    w!(out, "}};");
}

fn write_tables(
    out: &mut String,
    stages: &[String],
    stage_axes: &BTreeMap<String, Vec<usize>>,
    axes: &[Axis],
    perms: &[Permutation],
) {
    w!(out, "/// Every stage file under `shaders-glsl/` with its axes and all its compiled permutations.");
    w!(out, "pub const FILES: &[StageFile] = &[");
    for file in stages {
        let ids = stage_axes.get(file).cloned().unwrap_or_default();
        let names: Vec<String> = ids.iter().map(|&a| axes[a].name.clone()).collect();
        let permutations = if ids.is_empty() {
            let p = perms.iter().find(|p| &p.file == file).unwrap();
            format!("&[{}]", p.ident)
        } else {
            format!("{}::SOURCES", key_struct_name(file))
        };
        w!(
            out,
            "    StageFile {{ file: {file:?}, axes: &[{}], permutations: {permutations} }},",
            quoted(&names)
        );
    }
    w!(out, "];");
    w!(out, "/// Every compiled shader permutation, once.");
    w!(out, "pub const ALL: &[ShaderSource] = &[");
    for p in perms {
        w!(out, "    {},", p.ident);
    }
    w!(out, "];");
}
