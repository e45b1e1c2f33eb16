//! Checked GPU layouts: every compiled permutation of every stage file (`shaders::ALL`) against the
//! Rust side, by reflecting its SPIR-V ([`spirv`]):
//!
//! * every stage file has exactly one [`ShaderInterface`] (`crate::techniques::shader_interfaces`),
//!   and every interface numbers sets 0 and 1 [`FRAME_SET`] and [`OBJECT_SET`];
//! * every descriptor a shader declares is in its interface's table for that set, with the same
//!   descriptor type, count 1 and name: a buffer's block type name (`Materials`, not the instance),
//!   a sampler's or image's variable name (`albedo_texture`); every table entry is declared by some
//!   shader at that set;
//! * the push-constant block matches the interface's push struct: size (`size_of`), member names,
//!   offsets (`offset_of`), sizes and scalar types, in order; a struct member with a layout of its own
//!   ([`super::layout::GpuField::LAYOUT`]: the shading stages' `ShadePush` header) likewise;
//! * every struct of [`SHARED_STRUCTS`], wherever a shader lays it out (std140 or std430), matches the
//!   Rust struct the same way, arrays by length and `ArrayStride` (`lights[16]`: 80,
//!   `model_view[2]`: 64), and every array of it (`materials[]`) has `ArrayStride` = `size_of`; each
//!   must appear in some shader, so a rename on one side cannot leave it unchecked.
//!
//! The failure lists every mismatch as `file [permutations]: what`.

mod spirv;

use std::collections::{BTreeMap, BTreeSet};

use super::layout::{
    Binding, Component, ShaderInterface, SharedStruct, FRAME_SET, FRAME_SET_INDEX, OBJECT_SET,
    OBJECT_SET_INDEX, SHARED_STRUCTS, TECHNIQUE_OBJECT_SET_INDEX, TECHNIQUE_SET_INDEX,
};
use crate::shaders::{self, ShaderSource};
use crate::techniques::shader_interfaces;
use spirv::{LaidOutStruct, Reflection};

/// Mismatches, each with the permutations it was seen in.
#[derive(Default)]
struct Mismatches {
    /// (file, what) → permutations.
    by_file: BTreeMap<(&'static str, String), Vec<&'static str>>,
    other: Vec<String>,
}

impl Mismatches {
    fn shader(&mut self, source: &ShaderSource, what: String) {
        self.by_file.entry((source.file, what)).or_default().push(source.permutation);
    }

    fn finish(self) {
        let mut lines = self.other;
        for ((file, what), permutations) in self.by_file {
            let total = shaders::FILES.iter().find(|f| f.file == file).map_or(0, |f| f.permutations.len());
            let which = if permutations.len() == total && total > 1 {
                format!("all {total} permutations")
            } else {
                permutations.join(", ")
            };
            lines.push(format!("{file} [{which}]: {what}"));
        }
        assert!(
            lines.is_empty(),
            "{} mismatch(es) between the compiled shaders and the Rust side (gpu/layout.rs, the techniques' \
             SHADER_INTERFACES):\n  {}",
            lines.len(),
            lines.join("\n  ")
        );
    }
}

fn rust_component(c: Component) -> String {
    match c {
        Component::F32 => "f32".into(),
        Component::U32 => "u32".into(),
        Component::I32 => "i32".into(),
        Component::Struct(name) => format!("struct {name}"),
    }
}

/// Differences between a struct as a shader lays it out and its Rust mirror.
fn compare_struct(glsl: &LaidOutStruct, rust: &SharedStruct) -> Vec<String> {
    let mut out = Vec::new();
    let names = |v: Vec<&str>| v.join(", ");
    if glsl.members.len() != rust.members.len() {
        out.push(format!(
            "GLSL has {} members ({}), Rust {} ({})",
            glsl.members.len(),
            names(glsl.members.iter().map(|m| m.name.as_str()).collect()),
            rust.members.len(),
            names(rust.members.iter().map(|m| m.name).collect()),
        ));
    }
    for (g, r) in glsl.members.iter().zip(rust.members) {
        let member = &g.name;
        if g.name != r.name {
            out.push(format!("member `{member}` ({}) is `{}` in Rust", g.glsl, r.name));
        }
        if g.offset as usize != r.offset {
            out.push(format!("`{member}` ({}): offset {} in GLSL, {} in Rust", g.glsl, g.offset, r.offset));
        }
        if let Some(size) = g.size {
            if size as usize != r.size {
                out.push(format!("`{member}` ({}): {size} bytes in GLSL, {} in Rust", g.glsl, r.size));
            }
        }
        if let Some((length, stride)) = g.array {
            match r.array {
                None => out.push(format!("`{member}` ({}) is an array in GLSL, not in Rust", g.glsl)),
                Some((n, element)) => {
                    if let Some(length) = length {
                        if length as usize != n {
                            out.push(format!(
                                "`{member}` ({}): {length} elements in GLSL, {n} in Rust",
                                g.glsl
                            ));
                        }
                    }
                    if stride as usize != element {
                        out.push(format!(
                            "`{member}` ({}): ArrayStride {stride} in GLSL, element size {element} in Rust",
                            g.glsl
                        ));
                    }
                }
            }
        }
        let component = rust_component(r.component);
        if g.component != component {
            out.push(format!(
                "`{member}` ({}): made of {} in GLSL, of {component} in Rust",
                g.glsl, g.component
            ));
        }
    }
    if let Some(span) = glsl.span {
        if span as usize != rust.size {
            out.push(format!("{span} bytes in GLSL, size_of {} in Rust", rust.size));
        }
    }
    out
}

fn describe(table: &[Binding]) -> String {
    table.iter().map(|b| format!("{} `{}`", b.binding, b.block)).collect::<Vec<_>>().join(", ")
}

#[test]
fn compiled_shaders_match_the_rust_layouts() {
    // `ShaderInterface::sets` is indexed by set number.
    assert_eq!(
        [FRAME_SET_INDEX, OBJECT_SET_INDEX, TECHNIQUE_OBJECT_SET_INDEX, TECHNIQUE_SET_INDEX],
        [0, 1, 2, 3]
    );
    let interfaces: Vec<&ShaderInterface> = shader_interfaces().collect();
    let mut m = Mismatches::default();

    // The interfaces: one numbering, consistent tables, one interface per stage file.
    for i in &interfaces {
        let who = format!("the interface of {}", i.files.join(", "));
        if i.sets[0] != Some(&FRAME_SET[..]) || i.sets[1] != Some(&OBJECT_SET[..]) {
            m.other.push(format!(
                "{who}: sets 0 and 1 must be FRAME_SET and OBJECT_SET (one numbering for every pipeline: \
                 0 frame, 1 object, 2 technique per object, 3 technique; gpu/layout.rs)"
            ));
        }
        for (set, table) in i.sets.iter().enumerate() {
            let table = table.unwrap_or(&[]);
            let numbers: BTreeSet<u32> = table.iter().map(|b| b.binding).collect();
            if numbers.len() != table.len() {
                m.other.push(format!("{who}: set {set} lists a binding twice ({})", describe(table)));
            }
        }
    }
    for f in shaders::FILES {
        match interfaces.iter().filter(|i| i.files.contains(&f.file)).count() {
            1 => {}
            0 => m.other.push(format!(
                "{}: no ShaderInterface declares it (add it to the SHADER_INTERFACES of the technique that \
                 builds its pipeline)",
                f.file
            )),
            n => m.other.push(format!("{}: declared by {n} ShaderInterfaces", f.file)),
        }
    }
    for i in &interfaces {
        for file in i.files {
            if !shaders::FILES.iter().any(|f| f.file == *file) {
                m.other.push(format!(
                    "{file}: in a ShaderInterface, but no such stage file under shaders-glsl/"
                ));
            }
        }
    }

    // Every permutation against its interface.
    let mut declared: BTreeSet<(u32, u32, String)> = BTreeSet::new();
    let mut structs_seen: BTreeSet<&str> = BTreeSet::new();
    let mut pushes_seen: BTreeSet<usize> = BTreeSet::new();
    for source in shaders::ALL {
        let Some((index, interface)) =
            interfaces.iter().enumerate().find(|(_, i)| i.files.contains(&source.file))
        else {
            continue; // reported above
        };
        let spirv = match Reflection::new(source.spirv) {
            Ok(r) => r,
            Err(e) => {
                m.shader(source, e);
                continue;
            }
        };

        for d in spirv.descriptors() {
            let (set, binding, name) = (d.set, d.binding, &d.name);
            declared.insert((set, binding, name.clone()));
            let at = format!("set {set} binding {binding} `{name}`");
            let ty = match d.ty {
                Ok(ty) => ty,
                Err(e) => {
                    m.shader(source, format!("{at}: {e}"));
                    continue;
                }
            };
            let Some(table) = interface.sets.get(set as usize) else {
                m.shader(
                    source,
                    format!("{at}: no set {set} (sets: 0 frame, 1 object, 2 and 3 technique, 4 shadow maps)"),
                );
                continue;
            };
            let Some(entry) = table.unwrap_or(&[]).iter().find(|b| b.binding == binding) else {
                m.shader(source, format!("{at} ({ty:?}): not in its interface's set {set} table"));
                continue;
            };
            if entry.ty != ty {
                m.shader(source, format!("{at}: {ty:?} in GLSL, {:?} in the Rust table", entry.ty));
            }
            if entry.block != name {
                m.shader(source, format!("{at}: `{}` in the Rust table", entry.block));
            }
            if d.count != 1 {
                m.shader(source, format!("{at}: an array of {} descriptors; the tables bind one", d.count));
            }
        }

        match (spirv.push_block(), interface.push) {
            (None, _) => {}
            (Some(block), None) => m.shader(
                source,
                format!("declares push constants `{}`, but its interface has none", block.name),
            ),
            (Some(block), Some(rust)) => {
                pushes_seen.insert(index);
                for what in compare_struct(&block, &rust) {
                    m.shader(source, format!("push constants `{}`: {what}", block.name));
                }
                // A struct the block embeds with a layout of its own (a header: `ShadePush shade`).
                let structs = spirv.laid_out_structs();
                for nested in rust.members.iter().filter_map(|r| r.layout) {
                    let Some(s) = structs.iter().find(|s| s.name == nested.glsl) else {
                        m.shader(
                            source,
                            format!("push constants `{}`: no struct `{}` laid out", block.name, nested.glsl),
                        );
                        continue;
                    };
                    for what in compare_struct(s, nested) {
                        m.shader(
                            source,
                            format!("push constants `{}`, struct `{}`: {what}", block.name, s.name),
                        );
                    }
                }
            }
        }

        for s in spirv.laid_out_structs() {
            if let Some(rust) = SHARED_STRUCTS.iter().find(|r| r.glsl == s.name) {
                structs_seen.insert(rust.glsl);
                for what in compare_struct(&s, rust) {
                    m.shader(source, format!("struct `{}`: {what}", s.name));
                }
            }
        }
        for (name, stride) in spirv.struct_array_strides() {
            if let Some(rust) = SHARED_STRUCTS.iter().find(|r| r.glsl == name) {
                if stride as usize != rust.size {
                    m.shader(
                        source,
                        format!(
                            "arrays of `{name}`: ArrayStride {stride} in GLSL, size_of {} in Rust",
                            rust.size
                        ),
                    );
                }
            }
        }
    }

    // Nothing on the Rust side that no shader checked.
    for s in SHARED_STRUCTS {
        if !structs_seen.contains(s.glsl) {
            m.other
                .push(format!("SHARED_STRUCTS: `{}` is laid out in no compiled shader (renamed?)", s.glsl));
        }
    }
    for (index, i) in interfaces.iter().enumerate() {
        if let (Some(push), false) = (i.push, pushes_seen.contains(&index)) {
            m.other.push(format!(
                "the interface of {}: push constants `{}`, but none of its shaders declares any",
                i.files.join(", "),
                push.glsl
            ));
        }
        for (set, table) in i.sets.iter().enumerate() {
            for b in table.unwrap_or(&[]) {
                if !declared.contains(&(set as u32, b.binding, b.block.to_string())) {
                    m.other.push(format!(
                        "the interface of {}: set {set} binding {} `{}` is declared by no shader (stale?)",
                        i.files.join(", "),
                        b.binding,
                        b.block
                    ));
                }
            }
        }
    }
    m.finish();
}

/// The light kinds the GPU record carries match `common/frame.glsl`'s defines.
#[test]
fn light_kinds_match_the_glsl_defines() {
    use super::layout::{LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT};
    let frame = include_str!("../../../shaders-glsl/common/frame.glsl");
    for (name, value) in
        [("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL), ("LIGHT_POINT", LIGHT_POINT), ("LIGHT_SPOT", LIGHT_SPOT)]
    {
        let line = format!("#define {name} {value:.1}");
        assert!(frame.lines().any(|l| l.trim() == line), "frame.glsl lacks `{line}`");
    }
}

/// What the frame graph's declared-access check takes a pipeline to read
/// ([`crate::vk::statically_used_descriptors`]: the entry point's interface, nothing more) is, for
/// every compiled permutation, exactly the descriptors a full SPIR-V reflection finds in the module;
/// and a module with a descriptor the entry point does not list would be caught by that reflection
/// here, not missed by the check.
#[test]
fn statically_used_descriptors_match_the_reflection() {
    let mut checked = 0;
    for source in shaders::ALL {
        let words = ash::util::read_spv(&mut std::io::Cursor::new(source.spirv)).expect("SPIR-V words");
        let used = crate::vk::statically_used_descriptors(&words);
        let reflection = Reflection::new(source.spirv).expect("reflects");
        let mut reflected: Vec<(u32, u32)> =
            reflection.descriptors().iter().map(|d| (d.set, d.binding)).collect();
        reflected.sort_unstable();
        reflected.dedup();
        assert_eq!(used, reflected, "{} [{}]", source.file, source.permutation);
        checked += usize::from(!used.is_empty());
    }
    assert!(checked > 100, "only {checked} permutations read any descriptor");
}
