//! Test support: the layout of a WGSL struct as naga (wgpu's shader compiler) lays it
//! out, compared with the Rust `#[repr(C)]` struct that is uploaded as its bytes. Every
//! Rust/WGSL pair has a test beside the Rust struct: the same size, the same members in
//! the same order at the same offsets (`std::mem::offset_of!` on the Rust side), and every
//! field of the Rust struct named ([`every_field`]). A field added, removed, reordered or
//! retyped on one side only fails it.

/// Names every field of the Rust struct (a pattern without `..`), so that a field added to
/// it alone stops its layout test from compiling until the field is listed there too; the
/// list of members [`assert_same_layout`] is given cannot see such a field when it fits in
/// padding.
macro_rules! every_field {
    ($t:ident { $($f:ident),* $(,)? }) => {
        let _ = |v: $t| {
            let $t { $($f: _),* } = v;
        };
    };
}
pub(crate) use every_field;

/// A struct of a WGSL module as naga lays it out.
#[derive(Debug)]
pub(crate) struct WgslStruct {
    /// Size in bytes (the struct's span, its padding at the end included).
    pub span: u32,
    /// Each member's name and byte offset, in declaration order.
    pub members: Vec<(String, u32)>,
}

/// The struct `name` of the WGSL `source` (as the pipeline compiles it: see
/// [`crate::gpu::with_common`]); panics naming what is wrong.
pub(crate) fn wgsl_struct(source: &str, name: &str) -> WgslStruct {
    let module = naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("the WGSL does not parse: {}", e.emit_to_string(source)));
    let ty = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name} in the WGSL"))
        .1;
    match &ty.inner {
        naga::TypeInner::Struct { members, span } => WgslStruct {
            span: *span,
            members: members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                .collect(),
        },
        other => panic!("{name} is not a struct in the WGSL: {other:?}"),
    }
}

/// Asserts that the WGSL struct `name` of `source` is laid out as the Rust struct of
/// `rust_size` bytes whose members, in order, are `members` (the WGSL member's name and
/// the Rust offset of the bytes it reads, `offset_of!` plus the element's offset for a
/// Rust array read as several WGSL scalars).
pub(crate) fn assert_same_layout(
    source: &str,
    name: &str,
    rust_size: usize,
    members: &[(&str, usize)],
) {
    let wgsl = wgsl_struct(source, name);
    let names: Vec<&str> = wgsl.members.iter().map(|(n, _)| n.as_str()).collect();
    let expected: Vec<&str> = members.iter().map(|(n, _)| *n).collect();
    assert_eq!(
        names, expected,
        "{name}: the WGSL struct's members are not the Rust struct's"
    );
    for ((member, wgsl_offset), (_, rust_offset)) in wgsl.members.iter().zip(members) {
        assert_eq!(
            *wgsl_offset as usize, *rust_offset,
            "{name}.{member}: at byte {wgsl_offset} in the WGSL, {rust_offset} in Rust"
        );
    }
    assert_eq!(
        wgsl.span as usize, rust_size,
        "{name}: {} bytes in the WGSL, {rust_size} in Rust",
        wgsl.span
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_struct_is_read_with_its_padding_and_a_mismatch_is_named() {
        let src = "struct S { a: u32, b: vec3<f32>, c: f32, d: vec2<u32> }";
        let s = wgsl_struct(src, "S");
        // vec3 aligns to 16; the struct to 16 (its largest member alignment).
        assert_eq!(
            s.members,
            vec![
                ("a".to_owned(), 0),
                ("b".to_owned(), 16),
                ("c".to_owned(), 28),
                ("d".to_owned(), 32)
            ]
        );
        assert_eq!(s.span, 48);
        assert_same_layout(src, "S", 48, &[("a", 0), ("b", 16), ("c", 28), ("d", 32)]);
        let wrong = std::panic::catch_unwind(|| {
            assert_same_layout(src, "S", 48, &[("a", 0), ("b", 4), ("c", 28), ("d", 32)])
        });
        assert!(wrong.is_err(), "a member at another offset must fail");
    }
}
