//! GPU parameter structs declared once.
//!
//! A struct that a shader reads (a uniform block, a storage record) has two
//! declarations that must agree byte for byte: the Rust `#[repr(C)]` struct
//! the CPU fills, and the WGSL `struct` the shader reads. [`gpu_struct!`](macro@crate::gpu_struct)
//! takes the Rust declaration, with a WGSL type beside each field whose
//! Rust type does not name one by itself ([`WgslType`]), and yields:
//!
//! * the Rust struct, `#[repr(C)]`, `Pod` and `Zeroable`, with a
//!   compile-time check of its declared size;
//! * its WGSL `struct` text ([`GpuStruct::wgsl`]), which shaders include
//!   instead of spelling the struct out, so the two cannot drift;
//! * its layout ([`GpuStruct::layout`]: each member's name, offset and size
//!   as Rust lays them out), which [`check_layout`] compares with the offsets
//!   naga computes for the WGSL twin in a parsed shader: WGSL's alignment
//!   rules (a `vec3` aligned to 16 bytes, uniform arrays strided by 16)
//!   differ from Rust's, and only the shader compiler's own layout says
//!   whether the Rust struct needs explicit padding.
//!
//! A struct declared elsewhere (another crate's record) is checked the same
//! way through a layout written with [`gpu_layout!`](macro@crate::gpu_layout), or, when it is stored
//! in the place of a record and read through that record's members, with
//! [`check_overlay`].

use std::fmt::Write;

/// One member of a struct shared with WGSL, as Rust lays it out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    /// The member's name (the same in Rust and WGSL).
    pub name: &'static str,
    /// Byte offset in the Rust struct.
    pub offset: usize,
    /// Bytes of the Rust field.
    pub size: usize,
    /// The WGSL type the member is declared with (empty for a layout
    /// written by hand with [`gpu_layout!`](macro@crate::gpu_layout), which generates no WGSL).
    pub wgsl_type: &'static str,
}

/// A struct shared with WGSL: its name, its Rust size and its members in
/// declaration order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    /// The struct's name (the same in Rust and WGSL).
    pub name: &'static str,
    /// `size_of` the Rust struct.
    pub size: usize,
    /// Its members, in declaration order.
    pub fields: Vec<FieldLayout>,
}

impl StructLayout {
    /// The WGSL declaration of the struct: `struct Name { member: type, … }`.
    pub fn wgsl(&self) -> String {
        let mut out = format!("struct {} {{\n", self.name);
        for field in &self.fields {
            // Writing into a String cannot fail.
            let _ = writeln!(out, "    {}: {},", field.name, field.wgsl_type);
        }
        out.push_str("}\n");
        out
    }
}

/// A Rust struct with a WGSL twin, declared with [`gpu_struct!`](macro@crate::gpu_struct).
pub trait GpuStruct: bytemuck::Pod {
    /// The struct's name in both languages.
    const NAME: &'static str;

    /// Its members as Rust lays them out, with their WGSL types.
    fn layout() -> StructLayout;

    /// Its WGSL declaration, the text shaders include.
    fn wgsl() -> String {
        Self::layout().wgsl()
    }
}

/// The WGSL type a Rust field type stands for where there is only one
/// reading: scalars, `[T; 2..=4]` as vectors, `[[f32; 4]; 4]` as a
/// column-major `mat4x4<f32>`. Arrays (`array<vec4<f32>, 6>`, or a Rust
/// `[f32; 16]` packed as `array<vec4<f32>, 4>`) name their WGSL type in the
/// declaration instead.
pub trait WgslType {
    /// The WGSL spelling.
    const WGSL: &'static str;
}

macro_rules! wgsl_types {
    ($($rust:ty => $wgsl:literal),* $(,)?) => {
        $(impl WgslType for $rust {
            const WGSL: &'static str = $wgsl;
        })*
    };
}

wgsl_types! {
    f32 => "f32",
    u32 => "u32",
    i32 => "i32",
    [f32; 2] => "vec2<f32>",
    [f32; 3] => "vec3<f32>",
    [f32; 4] => "vec4<f32>",
    [u32; 2] => "vec2<u32>",
    [u32; 3] => "vec3<u32>",
    [u32; 4] => "vec4<u32>",
    [i32; 2] => "vec2<i32>",
    [i32; 3] => "vec3<i32>",
    [i32; 4] => "vec4<i32>",
    [[f32; 4]; 4] => "mat4x4<f32>",
}

/// Declares a struct shared with WGSL once: the Rust struct
/// (`#[repr(C)]`, `Clone`, `Copy`, `bytemuck::Pod`, `bytemuck::Zeroable`;
/// add other derives as attributes), a compile-time check of its size, and
/// its [`GpuStruct`] implementation (WGSL text and layout), and a
/// [`WgslType`] naming the struct, so another `gpu_struct!` may hold it as
/// a member (its WGSL declares both: include each struct's text). Each
/// field's WGSL type is its Rust type's [`WgslType`], or the literal after
/// `=>` (arrays: `array<vec4<f32>, 2>`, `array<Inner, 5>`; padding
/// `[u32; N]` as `array<u32, N>` in a storage record, since the Rust array
/// would otherwise read as a `vecN<u32>` with its 8- or 16-byte alignment;
/// a uniform block, whose arrays have a 16-byte stride, spells padding as
/// separate `u32` fields):
///
/// ```
/// oxygen_gpu::gpu_struct! {
///     /// A pass's parameters.
///     #[derive(Debug, Default)]
///     pub struct BlurParams: 48 bytes {
///         /// Texels to each side.
///         pub radius: u32,
///         /// Weights used.
///         pub count: u32,
///         /// Zero (a `vec2<u32>`, 8-byte aligned at offset 8).
///         pub reserved: [u32; 2],
///         /// Weights, packed four to a `vec4` (uniform arrays have a 16-byte stride).
///         pub weights: [f32; 8] => "array<vec4<f32>, 2>",
///     }
/// }
/// use oxygen_gpu::GpuStruct;
/// assert!(BlurParams::wgsl().contains("weights: array<vec4<f32>, 2>,"));
/// let module = naga::front::wgsl::parse_str(&BlurParams::wgsl()).unwrap();
/// oxygen_gpu::check_layout(&module, &BlurParams::layout()).unwrap();
/// ```
///
/// The crate using it depends on `bytemuck` (with its `derive` feature).
#[macro_export]
macro_rules! gpu_struct {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident : $size:literal bytes {
            $(
                $(#[$field_meta:meta])*
                $field_vis:vis $field:ident : $ty:ty $(=> $wgsl:literal)?
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, ::bytemuck::Pod, ::bytemuck::Zeroable)]
        $vis struct $name {
            $(
                $(#[$field_meta])*
                $field_vis $field: $ty,
            )*
        }

        const _: () = assert!(
            ::core::mem::size_of::<$name>() == $size,
            concat!("the size of ", stringify!($name), " is not the declared ", stringify!($size), " bytes")
        );

        // A member of another struct's type names the struct in WGSL.
        impl $crate::WgslType for $name {
            const WGSL: &'static str = stringify!($name);
        }

        impl $crate::GpuStruct for $name {
            const NAME: &'static str = stringify!($name);

            fn layout() -> $crate::StructLayout {
                $crate::StructLayout {
                    name: stringify!($name),
                    size: ::core::mem::size_of::<$name>(),
                    fields: ::std::vec![$(
                        $crate::FieldLayout {
                            name: stringify!($field),
                            offset: ::core::mem::offset_of!($name, $field),
                            size: ::core::mem::size_of::<$ty>(),
                            wgsl_type: $crate::gpu_struct!(@wgsl $ty $(, $wgsl)?),
                        },
                    )*],
                }
            }
        }
    };
    (@wgsl $ty:ty) => {
        <$ty as $crate::WgslType>::WGSL
    };
    (@wgsl $ty:ty, $wgsl:literal) => {
        $wgsl
    };
}

/// The [`StructLayout`] of a struct declared elsewhere (another crate's
/// record) whose WGSL twin is written by hand, for [`check_layout`]: every
/// Rust field in declaration order, each under its WGSL member name when
/// that differs (`field => "wgsl_name"`).
///
/// ```
/// #[repr(C)]
/// struct Pair { first: u32, second_value: u32 }
/// let layout = oxygen_gpu::gpu_layout!(Pair { first, second_value => "second" });
/// assert_eq!(layout.fields[1].name, "second");
/// assert_eq!(layout.fields[1].offset, 4);
/// ```
#[macro_export]
macro_rules! gpu_layout {
    (@build $ty:ty, $name:expr, [$($field:ident $(=> $wgsl_name:literal)?),*]) => {
        $crate::StructLayout {
            name: $name,
            size: ::core::mem::size_of::<$ty>(),
            fields: ::std::vec![$(
                $crate::FieldLayout {
                    name: $crate::gpu_layout!(@name $field $(, $wgsl_name)?),
                    offset: ::core::mem::offset_of!($ty, $field),
                    size: {
                        // The field's size, from a reference to it (no value needed).
                        fn size_of_field<T, F>(_: fn(&T) -> &F) -> usize {
                            ::core::mem::size_of::<F>()
                        }
                        size_of_field(|value: &$ty| &value.$field)
                    },
                    wgsl_type: "",
                },
            )*],
        }
    };
    (@name $field:ident) => {
        stringify!($field)
    };
    (@name $field:ident, $wgsl_name:literal) => {
        $wgsl_name
    };
    ($ty:ty as $name:literal { $($field:ident $(=> $wgsl_name:literal)?),* $(,)? }) => {
        $crate::gpu_layout!(@build $ty, $name, [$($field $(=> $wgsl_name)?),*])
    };
    ($ty:ident { $($field:ident $(=> $wgsl_name:literal)?),* $(,)? }) => {
        $crate::gpu_layout!(@build $ty, stringify!($ty), [$($field $(=> $wgsl_name)?),*])
    };
}

/// Compares `expected` with the struct of the same name in `module` (a
/// parsed shader): the same members in the same order, each at the same
/// offset with the same size, and the same struct size. The error lists
/// every difference.
pub fn check_layout(module: &naga::Module, expected: &StructLayout) -> Result<(), String> {
    let name = expected.name;
    let Some((_, ty)) = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)) else {
        return Err(format!("struct {name} is not declared in the shader"));
    };
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        return Err(format!("{name} is not a struct in the shader: {:?}", ty.inner));
    };
    let mut problems = Vec::new();
    if *span as usize != expected.size {
        problems.push(format!("size: WGSL {span}, Rust {}", expected.size));
    }
    let actual: Vec<(String, usize, usize)> = members
        .iter()
        .map(|m| {
            let size = module.types[m.ty].inner.size(module.to_ctx()) as usize;
            (m.name.clone().unwrap_or_default(), m.offset as usize, size)
        })
        .collect();
    for i in 0..actual.len().max(expected.fields.len()) {
        match (actual.get(i), expected.fields.get(i)) {
            (Some((wgsl_name, offset, size)), Some(field)) => {
                if wgsl_name != field.name {
                    problems.push(format!("member {i}: WGSL `{wgsl_name}`, Rust `{}`", field.name));
                } else if (*offset, *size) != (field.offset, field.size) {
                    problems.push(format!(
                        "{wgsl_name}: WGSL offset {offset} size {size}, Rust offset {} size {}",
                        field.offset, field.size
                    ));
                }
            }
            (Some((wgsl_name, ..)), None) => problems.push(format!("WGSL member `{wgsl_name}` has no Rust field")),
            (None, Some(field)) => problems.push(format!("Rust field `{}` has no WGSL member", field.name)),
            (None, None) => {}
        }
    }
    if problems.is_empty() { Ok(()) } else { Err(format!("{name}: {}", problems.join("; "))) }
}

/// Compares a Rust struct stored in a record's place with the record's
/// layout: `overlay` (the struct's [`gpu_layout!`](macro@crate::gpu_layout), each field named by the
/// first member of `record` it lies on) must have `record`'s size, and each
/// field must start where its named member starts and run over whole
/// members, the fields one after the other without gaps. A shader reading
/// the record's members then reads the struct's bytes: what lets one
/// storage array hold several 32-byte records (a vertex, its attributes,
/// its skin) declared once in Rust and once, as the record, in WGSL. The
/// error lists every difference.
pub fn check_overlay(record: &StructLayout, overlay: &StructLayout) -> Result<(), String> {
    let mut problems = Vec::new();
    if overlay.size != record.size {
        problems.push(format!("size {}, {} has {}", overlay.size, record.name, record.size));
    }
    let mut expected_offset = 0;
    for field in &overlay.fields {
        let Some(first) = record.fields.iter().position(|m| m.name == field.name) else {
            problems.push(format!("`{}`: {} has no member of that name", field.name, record.name));
            continue;
        };
        let start = record.fields[first].offset;
        if field.offset != start {
            problems.push(format!("`{}` at offset {}, the member at {start}", field.name, field.offset));
        }
        if field.offset != expected_offset {
            problems.push(format!(
                "`{}` at offset {}, the field before ends at {expected_offset}",
                field.name, field.offset
            ));
        }
        let end = field.offset + field.size;
        if !record.fields.iter().any(|m| m.offset + m.size == end) {
            problems.push(format!("`{}` ends at {end}, inside a member of {}", field.name, record.name));
        }
        expected_offset = end;
    }
    if expected_offset != overlay.size {
        problems.push(format!("the fields end at {expected_offset}, the struct at {}", overlay.size));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!("{} over {}: {}", overlay.name, record.name, problems.join("; ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::gpu_struct! {
        /// A struct exercising every kind of member.
        #[derive(Debug, PartialEq)]
        struct Sample: 112 bytes {
            /// A matrix.
            transform: [[f32; 4]; 4],
            /// A vec3 followed by a scalar in its tail.
            position: [f32; 3],
            count: u32,
            /// Packed floats.
            weights: [f32; 8] => "array<vec4<f32>, 2>",
        }
    }

    crate::gpu_struct! {
        /// A struct holding another, once and in an array.
        struct Outer: 240 bytes {
            first: Sample,
            flags: u32,
            /// Padding of a storage record.
            reserved: [u32; 3] => "array<u32, 3>",
            rest: [Sample; 1] => "array<Sample, 1>",
        }
    }

    fn parse(source: &str) -> naga::Module {
        naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{}", e.emit_to_string(source)))
    }

    #[test]
    fn the_generated_wgsl_has_the_rust_layout() {
        assert_eq!(
            Sample::wgsl(),
            "struct Sample {\n    transform: mat4x4<f32>,\n    position: vec3<f32>,\n    count: u32,\n    \
             weights: array<vec4<f32>, 2>,\n}\n"
        );
        let module = parse(&Sample::wgsl());
        check_layout(&module, &Sample::layout()).expect("same layout");
    }

    #[test]
    fn a_struct_member_names_the_struct() {
        assert!(Outer::wgsl().contains("    first: Sample,\n"), "{}", Outer::wgsl());
        let module = parse(&(Sample::wgsl() + &Outer::wgsl()));
        check_layout(&module, &Outer::layout()).expect("same layout");
    }

    #[test]
    fn a_different_layout_is_reported_member_by_member() {
        // `count` moved past a vec4 and the struct grew.
        let module = parse(
            "struct Sample { transform: mat4x4<f32>, position: vec3<f32>, other: u32, \
             weights: array<vec4<f32>, 2>, count: u32 }",
        );
        let error = check_layout(&module, &Sample::layout()).expect_err("differs");
        assert!(error.contains("size: WGSL 128, Rust 112"), "{error}");
        assert!(error.contains("member 2: WGSL `other`, Rust `count`"), "{error}");
        assert!(error.contains("WGSL member `count` has no Rust field"), "{error}");
        let missing = check_layout(&parse("struct Other { a: u32 }"), &Sample::layout()).expect_err("absent");
        assert!(missing.contains("not declared"), "{missing}");
    }

    #[test]
    fn a_hand_written_layout_renames_members() {
        #[repr(C)]
        struct Pair {
            first: u32,
            second_value: [f32; 3],
        }
        let layout = crate::gpu_layout!(Pair { first, second_value => "second" });
        assert_eq!(layout.name, "Pair");
        assert_eq!(layout.size, 16);
        assert_eq!((layout.fields[1].name, layout.fields[1].offset, layout.fields[1].size), ("second", 4, 12));
        // WGSL aligns the vec3 to 16: the check catches what Rust packs tighter.
        let module = parse("struct Pair { first: u32, second: vec3<f32> }");
        let error = check_layout(&module, &layout).expect_err("vec3 alignment");
        assert!(error.contains("second: WGSL offset 16 size 12, Rust offset 4 size 12"), "{error}");
    }

    #[test]
    fn an_overlay_lies_over_whole_members_of_its_record() {
        crate::gpu_struct! {
            /// Four scalars.
            struct Quad: 16 bytes { a: f32, b: f32, c: f32, d: f32 }
        }
        #[repr(C)]
        struct Split {
            head: [f32; 3],
            tail: f32,
        }
        let record = Quad::layout();
        check_overlay(&record, &crate::gpu_layout!(Split { head => "a", tail => "d" })).expect("lies over a..c, d");
        // Named after the wrong member, or ending inside one.
        let error = check_overlay(&record, &crate::gpu_layout!(Split { head => "a", tail => "c" })).expect_err("c");
        assert!(error.contains("`c` at offset 12, the member at 8"), "{error}");
        #[repr(C)]
        struct Halves {
            first: [u16; 3],
            rest: [u16; 5],
        }
        let error = check_overlay(&record, &crate::gpu_layout!(Halves { first => "a", rest => "b" })).expect_err("odd");
        assert!(error.contains("`a` ends at 6, inside a member of Quad"), "{error}");
        assert!(error.contains("`b` at offset 6, the member at 4"), "{error}");
        // A field left out of the overlay leaves a gap.
        let error = check_overlay(&record, &crate::gpu_layout!(Split { tail => "d" })).expect_err("gap");
        assert!(error.contains("the field before ends at 0"), "{error}");
    }
}
