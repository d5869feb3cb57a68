//! One source of truth for the memory shared with the shaders: each uniform or storage struct
//! is declared once in Rust with `gpu_struct!`, which derives `bytemuck::Pod` and records
//! every field's name, offset and scalar type. A unit test beside each driver checks that
//! record against the WGSL declaration of the same name, parsed by naga (`check`), so a
//! field added, reordered or retyped on one side only fails a test instead of reading garbage.
// The record is read by those tests only.
#![cfg_attr(not(test), allow(dead_code))]

/// A WGSL scalar type, as a Rust field of a shared struct may have.
pub trait WgslScalar {
    /// Its WGSL name.
    const WGSL: &'static str;
}

impl WgslScalar for u32 {
    const WGSL: &'static str = "u32";
}
impl WgslScalar for i32 {
    const WGSL: &'static str = "i32";
}
impl WgslScalar for f32 {
    const WGSL: &'static str = "f32";
}

/// One field of a shared struct.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Member {
    /// Its name, the same on both sides.
    pub name: &'static str,
    /// Byte offset.
    pub offset: usize,
    /// WGSL scalar type.
    pub ty: &'static str,
}

/// A struct laid out as a WGSL struct of the name [`WgslStruct::WGSL_NAME`].
pub trait WgslStruct: bytemuck::Pod {
    /// The struct's name in the WGSL source.
    const WGSL_NAME: &'static str;
    /// Its fields in declaration order.
    fn members() -> Vec<Member>;
}

/// Declares a `#[repr(C)]`, `Pod` struct shared with WGSL, field by field as the shader
/// declares it, and implements [`WgslStruct`] for it.
macro_rules! gpu_struct {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident as $wgsl:literal {
            $($(#[$fmeta:meta])* $fvis:vis $field:ident : $fty:ty),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
        $vis struct $name {
            $($(#[$fmeta])* $fvis $field: $fty),+
        }

        impl $crate::gpu::layout::WgslStruct for $name {
            const WGSL_NAME: &'static str = $wgsl;
            fn members() -> Vec<$crate::gpu::layout::Member> {
                vec![$($crate::gpu::layout::Member {
                    name: stringify!($field),
                    offset: std::mem::offset_of!($name, $field),
                    ty: <$fty as $crate::gpu::layout::WgslScalar>::WGSL,
                }),+]
            }
        }
    };
}
pub(crate) use gpu_struct;

/// Checks `T` against the struct of the same name in `source`: size, and every member's name,
/// offset and scalar type.
#[cfg(test)]
pub(crate) fn check<T: WgslStruct>(source: &str) {
    check_as::<T>(source, T::WGSL_NAME)
}

/// [`check`] against the struct `name` (a shader that names the same layout differently).
#[cfg(test)]
pub(crate) fn check_as<T: WgslStruct>(source: &str, name: &str) {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
    let declared = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name} in the shader"));
    let naga::TypeInner::Struct { members, span } = &declared.1.inner else {
        panic!("{name} is not a struct in the shader");
    };
    assert_eq!(*span as usize, std::mem::size_of::<T>(), "size of {name}");
    let ours = T::members();
    let theirs: Vec<Member> = members
        .iter()
        .map(|m| Member {
            name: ours
                .iter()
                .map(|o| o.name)
                .find(|n| Some(*n) == m.name.as_deref())
                .unwrap_or("(a member the Rust struct lacks)"),
            offset: m.offset as usize,
            // An atomic has its scalar's layout; the Rust side reads it as that scalar.
            ty: match module.types[m.ty].inner {
                naga::TypeInner::Scalar(naga::Scalar { kind, width: 4 })
                | naga::TypeInner::Atomic(naga::Scalar { kind, width: 4 }) => match kind {
                    naga::ScalarKind::Uint => "u32",
                    naga::ScalarKind::Sint => "i32",
                    naga::ScalarKind::Float => "f32",
                    _ => "other",
                },
                _ => "not a 32-bit scalar",
            },
        })
        .collect();
    assert_eq!(ours, theirs, "{name} in Rust against WGSL");
}
