//! A small typed view of one SPIR-V module, enough to compare it with the Rust side: its descriptor
//! bindings, its push-constant block and every struct with an explicit layout (`Offset`,
//! `ArrayStride`, `MatrixStride`). Names come from `OpName`/`OpMemberName`: `build.rs` compiles with
//! debug info (the optimizer strips names without it) and drops only the source text and line
//! table; without names nothing here can be matched.

use std::collections::HashMap;

use ash::vk;
use rspirv::dr::{Instruction, Operand};
use rspirv::spirv::{Decoration, Dim, Op, StorageClass, Word};

enum Type {
    Bool,
    Int {
        width: u32,
        signed: bool,
    },
    Float {
        width: u32,
    },
    Vector {
        component: Word,
        count: u32,
    },
    Matrix {
        column: Word,
        columns: u32,
    },
    /// `length`: `None` for a runtime array.
    Array {
        element: Word,
        length: Option<u32>,
    },
    Struct {
        members: Vec<Word>,
    },
    Image {
        dim: Dim,
        sampled: u32,
    },
    SampledImage,
    Sampler,
    AccelerationStructure,
    Pointer {
        pointee: Word,
    },
    Other,
}

/// A variable bound to a descriptor.
pub struct DescriptorBinding {
    pub set: u32,
    pub binding: u32,
    /// `Err`: a kind of resource the tables cannot express.
    pub ty: Result<vk::DescriptorType, String>,
    /// Descriptors (an array of them: its length; 0 unsized).
    pub count: u32,
    /// The block's type name for a buffer, the variable's name otherwise (`vk::Binding::block`).
    pub name: String,
}

/// A struct type with an explicit layout (a block, or a struct inside one).
pub struct LaidOutStruct {
    pub name: String,
    pub members: Vec<LaidOutMember>,
    /// The end of its last member; `None` when that is a runtime array.
    pub span: Option<u32>,
}

pub struct LaidOutMember {
    pub name: String,
    pub offset: u32,
    /// `None` for a runtime array.
    pub size: Option<u32>,
    /// The outermost array's `(length, ArrayStride)`; length `None` for a runtime array.
    pub array: Option<(Option<u32>, u32)>,
    /// The scalar (or struct) under any arrays, vectors and matrices: `f32`, `u32`, `i32`,
    /// `struct Light`, ...
    pub component: String,
    /// Its GLSL type, for messages (`mat4[2]`, `float[3]`, `vec4`).
    pub glsl: String,
}

/// (decoration, its literal operands) of one id or member.
type Decorations = Vec<(Decoration, Vec<u32>)>;

pub struct Reflection {
    types: HashMap<Word, Type>,
    constants: HashMap<Word, u32>,
    names: HashMap<Word, String>,
    member_names: HashMap<(Word, u32), String>,
    /// `OpDecorate`: target → (decoration, literal operands).
    decorations: HashMap<Word, Decorations>,
    /// `OpMemberDecorate`: (struct, member) → (decoration, literal operands).
    member_decorations: HashMap<(Word, u32), Decorations>,
    /// Global variables: (id, pointer type, storage class), in module order.
    variables: Vec<(Word, Word, StorageClass)>,
    /// Struct ids in module order (the map above has none).
    structs: Vec<Word>,
}

fn id(op: &Operand) -> Word {
    match op {
        Operand::IdRef(w) => *w,
        other => panic!("expected an id, found {other:?}"),
    }
}

fn literal(op: &Operand) -> u32 {
    match op {
        Operand::LiteralBit32(w) => *w,
        other => panic!("expected a 32-bit literal, found {other:?}"),
    }
}

fn string(op: &Operand) -> String {
    match op {
        Operand::LiteralString(s) => s.clone(),
        other => panic!("expected a string, found {other:?}"),
    }
}

fn literals(ops: &[Operand]) -> Vec<u32> {
    ops.iter().filter_map(|o| if let Operand::LiteralBit32(w) = o { Some(*w) } else { None }).collect()
}

/// The module's words without `OpSource`/`OpSourceContinued`: glslang cuts the embedded source text
/// into chunks at byte boundaries, splitting multi-byte UTF-8 characters (`→` in a comment), which
/// rspirv refuses to decode. Nothing here needs the source text.
fn without_source_text(spirv: &[u8]) -> Result<Vec<u32>, String> {
    let chunks = spirv.chunks_exact(4);
    if !chunks.remainder().is_empty() || spirv.len() < 20 {
        return Err(format!("{} bytes are not a SPIR-V module", spirv.len()));
    }
    let words: Vec<u32> = chunks.map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect();
    let mut out = words[..5].to_vec();
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let opcode = words[at] & 0xffff;
        if count == 0 || at + count > words.len() {
            return Err(format!("malformed instruction at word {at}"));
        }
        if opcode != Op::Source as u32 && opcode != Op::SourceContinued as u32 {
            out.extend_from_slice(&words[at..at + count]);
        }
        at += count;
    }
    Ok(out)
}

impl Reflection {
    pub fn new(spirv: &[u8]) -> Result<Self, String> {
        let module = rspirv::dr::load_words(without_source_text(spirv)?)
            .map_err(|e| format!("cannot parse the SPIR-V: {e}"))?;
        let mut r = Reflection {
            types: HashMap::new(),
            constants: HashMap::new(),
            names: HashMap::new(),
            member_names: HashMap::new(),
            decorations: HashMap::new(),
            member_decorations: HashMap::new(),
            variables: Vec::new(),
            structs: Vec::new(),
        };
        for i in &module.debug_names {
            match i.class.opcode {
                Op::Name => {
                    r.names.insert(id(&i.operands[0]), string(&i.operands[1]));
                }
                Op::MemberName => {
                    let key = (id(&i.operands[0]), literal(&i.operands[1]));
                    r.member_names.insert(key, string(&i.operands[2]));
                }
                _ => {}
            }
        }
        for i in &module.annotations {
            let decoration = |op: &Operand| match op {
                Operand::Decoration(d) => *d,
                other => panic!("expected a decoration, found {other:?}"),
            };
            match i.class.opcode {
                Op::Decorate => {
                    let d = (decoration(&i.operands[1]), literals(&i.operands[2..]));
                    r.decorations.entry(id(&i.operands[0])).or_default().push(d);
                }
                Op::MemberDecorate => {
                    let key = (id(&i.operands[0]), literal(&i.operands[1]));
                    let d = (decoration(&i.operands[2]), literals(&i.operands[3..]));
                    r.member_decorations.entry(key).or_default().push(d);
                }
                _ => {}
            }
        }
        for i in &module.types_global_values {
            r.declare(i);
        }
        Ok(r)
    }

    fn declare(&mut self, i: &Instruction) {
        let ops = &i.operands;
        let ty = match i.class.opcode {
            Op::TypeBool => Type::Bool,
            Op::TypeInt => Type::Int { width: literal(&ops[0]), signed: literal(&ops[1]) != 0 },
            Op::TypeFloat => Type::Float { width: literal(&ops[0]) },
            Op::TypeVector => Type::Vector { component: id(&ops[0]), count: literal(&ops[1]) },
            Op::TypeMatrix => Type::Matrix { column: id(&ops[0]), columns: literal(&ops[1]) },
            Op::TypeArray => {
                Type::Array { element: id(&ops[0]), length: self.constants.get(&id(&ops[1])).copied() }
            }
            Op::TypeRuntimeArray => Type::Array { element: id(&ops[0]), length: None },
            Op::TypeStruct => Type::Struct { members: ops.iter().map(id).collect() },
            Op::TypeImage => {
                let dim = match ops[1] {
                    Operand::Dim(d) => d,
                    ref other => panic!("expected a dimension, found {other:?}"),
                };
                Type::Image { dim, sampled: literal(&ops[5]) }
            }
            Op::TypeSampledImage => Type::SampledImage,
            Op::TypeSampler => Type::Sampler,
            Op::TypeAccelerationStructureKHR => Type::AccelerationStructure,
            Op::TypePointer => Type::Pointer { pointee: id(&ops[1]) },
            Op::Constant | Op::SpecConstant => {
                if let (Some(result), Some(Operand::LiteralBit32(v))) = (i.result_id, ops.first()) {
                    self.constants.insert(result, *v);
                }
                return;
            }
            Op::Variable => {
                if let (Some(result), Some(ty), Some(Operand::StorageClass(class))) =
                    (i.result_id, i.result_type, ops.first())
                {
                    self.variables.push((result, ty, *class));
                }
                return;
            }
            _ => Type::Other,
        };
        if let Some(result) = i.result_id {
            if matches!(ty, Type::Struct { .. }) {
                self.structs.push(result);
            }
            self.types.insert(result, ty);
        }
    }

    fn name(&self, id: Word) -> String {
        self.names.get(&id).cloned().unwrap_or_else(|| format!("%{id}"))
    }

    fn decoration(&self, id: Word, which: Decoration) -> Option<&[u32]> {
        self.decorations.get(&id)?.iter().find(|(d, _)| *d == which).map(|(_, v)| v.as_slice())
    }

    fn member_decoration(&self, s: Word, member: u32, which: Decoration) -> Option<&[u32]> {
        let all = self.member_decorations.get(&(s, member))?;
        all.iter().find(|(d, _)| *d == which).map(|(_, v)| v.as_slice())
    }

    fn has(&self, id: Word, which: Decoration) -> bool {
        self.decoration(id, which).is_some()
    }

    fn pointee(&self, pointer: Word) -> Word {
        match self.types.get(&pointer) {
            Some(Type::Pointer { pointee }) => *pointee,
            _ => panic!("%{pointer} is not a pointer type"),
        }
    }

    /// Every descriptor the module declares (its resources in use: the compiler drops the others).
    pub fn descriptors(&self) -> Vec<DescriptorBinding> {
        let mut out = Vec::new();
        for &(var, ptr, class) in &self.variables {
            if !matches!(
                class,
                StorageClass::Uniform | StorageClass::UniformConstant | StorageClass::StorageBuffer
            ) {
                continue;
            }
            let (Some(&[set]), Some(&[binding])) =
                (self.decoration(var, Decoration::DescriptorSet), self.decoration(var, Decoration::Binding))
            else {
                continue;
            };
            let mut ty_id = self.pointee(ptr);
            let mut count = 1;
            if let Some(Type::Array { element, length }) = self.types.get(&ty_id) {
                count = length.unwrap_or(0);
                ty_id = *element;
            }
            let is_struct = matches!(self.types.get(&ty_id), Some(Type::Struct { .. }));
            let ty = match (class, self.types.get(&ty_id)) {
                (StorageClass::StorageBuffer, _) => Ok(vk::DescriptorType::STORAGE_BUFFER),
                (StorageClass::Uniform, _) if self.has(ty_id, Decoration::BufferBlock) => {
                    Ok(vk::DescriptorType::STORAGE_BUFFER)
                }
                (StorageClass::Uniform, _) => Ok(vk::DescriptorType::UNIFORM_BUFFER),
                (_, Some(Type::SampledImage)) => Ok(vk::DescriptorType::COMBINED_IMAGE_SAMPLER),
                (_, Some(Type::Sampler)) => Ok(vk::DescriptorType::SAMPLER),
                (_, Some(Type::AccelerationStructure)) => Ok(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR),
                (_, Some(Type::Image { dim, sampled })) => match (dim, sampled) {
                    (Dim::DimSubpassData, _) => Ok(vk::DescriptorType::INPUT_ATTACHMENT),
                    (Dim::DimBuffer, 1) => Ok(vk::DescriptorType::UNIFORM_TEXEL_BUFFER),
                    (Dim::DimBuffer, _) => Ok(vk::DescriptorType::STORAGE_TEXEL_BUFFER),
                    (_, 1) => Ok(vk::DescriptorType::SAMPLED_IMAGE),
                    (_, 2) => Ok(vk::DescriptorType::STORAGE_IMAGE),
                    _ => Err(format!("an image of unknown use (Sampled = {sampled})")),
                },
                _ => Err("a resource of unknown kind".to_string()),
            };
            let name = if is_struct { self.name(ty_id) } else { self.name(var) };
            out.push(DescriptorBinding { set, binding, ty, count, name });
        }
        out
    }

    /// The push-constant block, if the module uses one.
    pub fn push_block(&self) -> Option<LaidOutStruct> {
        let &(_, ptr, _) = self.variables.iter().find(|(_, _, c)| *c == StorageClass::PushConstant)?;
        Some(self.laid_out(self.pointee(ptr)))
    }

    /// Every struct with an explicit layout: blocks and the structs inside them (not the compiler's
    /// undecorated copies of them in function memory, which share their names).
    pub fn laid_out_structs(&self) -> Vec<LaidOutStruct> {
        self.structs
            .iter()
            .filter(|&&s| self.member_decoration(s, 0, Decoration::Offset).is_some())
            .map(|&s| self.laid_out(s))
            .collect()
    }

    /// `(element struct name, ArrayStride)` of every array of structs with an explicit stride (the
    /// records of storage buffers, `lights[MAX_LIGHTS]`).
    pub fn struct_array_strides(&self) -> Vec<(String, u32)> {
        let mut out = Vec::new();
        for (&array, ty) in &self.types {
            if let Type::Array { element, .. } = ty {
                if let (Some(Type::Struct { .. }), Some(&[stride])) =
                    (self.types.get(element), self.decoration(array, Decoration::ArrayStride))
                {
                    out.push((self.name(*element), stride));
                }
            }
        }
        out.sort();
        out
    }

    fn laid_out(&self, s: Word) -> LaidOutStruct {
        let Some(Type::Struct { members }) = self.types.get(&s) else { panic!("%{s} is not a struct") };
        let members: Vec<LaidOutMember> = members
            .iter()
            .enumerate()
            .map(|(i, &ty)| {
                let i = i as u32;
                let name = self.member_names.get(&(s, i)).cloned().unwrap_or_else(|| format!("#{i}"));
                let offset = self.member_decoration(s, i, Decoration::Offset).map_or(0, |v| v[0]);
                let matrix_stride = self.member_decoration(s, i, Decoration::MatrixStride).map(|v| v[0]);
                let row_major = self.member_decoration(s, i, Decoration::RowMajor).is_some();
                let array = match self.types.get(&ty) {
                    Some(Type::Array { length, .. }) => {
                        Some((*length, self.decoration(ty, Decoration::ArrayStride).map_or(0, |v| v[0])))
                    }
                    _ => None,
                };
                LaidOutMember {
                    name,
                    offset,
                    size: self.size(ty, matrix_stride, row_major),
                    array,
                    component: self.component(ty),
                    glsl: self.glsl(ty),
                }
            })
            .collect();
        let span = members
            .iter()
            .map(|m| m.size.map(|size| m.offset + size))
            .try_fold(0, |end, m| m.map(|m| end.max(m)));
        LaidOutStruct { name: self.name(s), members, span }
    }

    /// Bytes of a value of type `ty` in a block (`None`: a runtime array). `matrix_stride` and
    /// `row_major` are the decorations of the member it is (or is an array of).
    fn size(&self, ty: Word, matrix_stride: Option<u32>, row_major: bool) -> Option<u32> {
        Some(match self.types.get(&ty)? {
            Type::Bool => 4,
            Type::Int { width, .. } | Type::Float { width } => width / 8,
            Type::Vector { component, count } => count * self.size(*component, None, false)?,
            Type::Matrix { column, columns } => {
                let Some(Type::Vector { count: rows, .. }) = self.types.get(column) else { return None };
                match matrix_stride {
                    Some(stride) if row_major => rows * stride,
                    Some(stride) => columns * stride,
                    None => columns * self.size(*column, None, false)?,
                }
            }
            Type::Array { element, length } => {
                let stride = match self.decoration(ty, Decoration::ArrayStride) {
                    Some(v) => v[0],
                    None => self.size(*element, matrix_stride, row_major)?,
                };
                (*length)? * stride
            }
            Type::Struct { .. } => self.laid_out(ty).span?,
            _ => return None,
        })
    }

    fn component(&self, ty: Word) -> String {
        match self.types.get(&ty) {
            Some(Type::Float { width: 32 }) => "f32".into(),
            Some(Type::Int { width: 32, signed: false }) => "u32".into(),
            Some(Type::Int { width: 32, signed: true }) => "i32".into(),
            Some(
                Type::Vector { component: e, .. }
                | Type::Matrix { column: e, .. }
                | Type::Array { element: e, .. },
            ) => self.component(*e),
            Some(Type::Struct { .. }) => format!("struct {}", self.name(ty)),
            _ => self.glsl(ty),
        }
    }

    fn glsl(&self, ty: Word) -> String {
        let prefix = |component: Word| match self.types.get(&component) {
            Some(Type::Int { signed: false, .. }) => "u",
            Some(Type::Int { signed: true, .. }) => "i",
            Some(Type::Bool) => "b",
            Some(Type::Float { width: 64 }) => "d",
            _ => "",
        };
        match self.types.get(&ty) {
            Some(Type::Bool) => "bool".into(),
            Some(Type::Int { width: 32, signed: false }) => "uint".into(),
            Some(Type::Int { width: 32, signed: true }) => "int".into(),
            Some(Type::Float { width: 32 }) => "float".into(),
            Some(Type::Int { width, signed }) => format!("{}int{width}", if *signed { "" } else { "u" }),
            Some(Type::Float { width }) => format!("float{width}"),
            Some(Type::Vector { component, count }) => format!("{}vec{count}", prefix(*component)),
            Some(Type::Matrix { column, columns }) => match self.types.get(column) {
                Some(Type::Vector { component, count }) if count == columns => {
                    format!("{}mat{columns}", prefix(*component))
                }
                Some(Type::Vector { component, count }) => {
                    format!("{}mat{columns}x{count}", prefix(*component))
                }
                _ => "matrix".into(),
            },
            Some(Type::Array { element, length: Some(n) }) => format!("{}[{n}]", self.glsl(*element)),
            Some(Type::Array { element, length: None }) => format!("{}[]", self.glsl(*element)),
            Some(Type::Struct { .. }) => self.name(ty),
            _ => format!("%{ty}"),
        }
    }
}
