//! The comparison of a params block with the layout the host recorded, and the
//! message that names the first difference.

use raykit_abi::{ParamsLayout, ScalarKind, Shape, PARAMS_BINDING, PARAMS_SET, PUSH_CONSTANT_BUDGET};

use super::{BlockMember, BlockType, LayoutError, ParamsBlock, ParamsDelivery, Result};

/// A disagreement between the host's struct and the SPIR-V.
struct Mismatch {
    field: String,
    host: String,
    device: String,
    depth: usize,
}

fn describe_host(offset: u32, size: u32) -> String {
    format!("offset {offset}, size {size}")
}

/// How a message names SPIR-V member `index` (with its `OpMemberName` when the module has one).
fn member_label(member: &BlockMember, index: usize) -> String {
    match &member.name {
        Some(name) => format!("SPIR-V member {index} `{name}`"),
        None => format!("SPIR-V member {index}"),
    }
}

/// Compares the host layout with the block members, pairing each host field with
/// the member at its offset; `Err` on the first difference.
fn compare(
    host: &ParamsLayout,
    members: &[BlockMember],
    path: &str,
    depth: usize,
) -> std::result::Result<(), Mismatch> {
    let at = |name: &str| if path.is_empty() { name.to_owned() } else { format!("{path}.{name}") };
    for field in host.fields {
        let host_text = format!("{}, type {}", describe_host(field.offset, field.size), field.type_name);
        let Some((index, member)) = members.iter().enumerate().find(|(_, m)| m.offset == field.offset) else {
            let covering = members
                .iter()
                .enumerate()
                .find(|(_, m)| m.offset < field.offset && field.offset < m.offset.saturating_add(m.size.max(1)));
            let same_name = members.iter().enumerate().find(|(_, m)| m.name.as_deref() == Some(field.name));
            let device = match (same_name, covering) {
                (Some((i, m)), _) => format!("{}: offset {}, size {}", member_label(m, i), m.offset, m.size),
                (None, Some((i, m))) => format!(
                    "no member starts at offset {}: {} (offset {}, size {}) covers it",
                    field.offset,
                    member_label(m, i),
                    m.offset,
                    m.size
                ),
                (None, None) => {
                    let offsets: Vec<u32> = members.iter().map(|m| m.offset).collect();
                    format!("absent: no member at offset {} (the block's members start at {offsets:?})", field.offset)
                }
            };
            return Err(Mismatch { field: at(field.name), host: host_text, device, depth });
        };
        let mismatch = |device: String| Mismatch {
            field: at(field.name),
            host: host_text.clone(),
            device: format!("{}: {device}", member_label(member, index)),
            depth,
        };
        match (&field.shape, &member.ty) {
            (Shape::Struct(inner), BlockType::Struct(inner_members)) => {
                compare(inner, inner_members, &at(field.name), depth + 1)?;
            }
            (Shape::Array { stride, len, .. }, BlockType::Array { stride: s, len: l, .. }) => {
                if stride != s || len != l {
                    return Err(mismatch(format!("array of {l} with stride {s} (host: {len} with stride {stride})")));
                }
            }
            (Shape::Matrix { column_stride, .. }, BlockType::Matrix { column_stride: s, .. }) => {
                if column_stride != s {
                    return Err(mismatch(format!("matrix column stride {s} (host: {column_stride})")));
                }
            }
            // rust-gpu lays glam's matrices out as structs of column vectors.
            (Shape::Matrix { columns, column_stride }, BlockType::Struct(cols)) => {
                let stride_ok = cols.len() == *columns as usize
                    && cols
                        .iter()
                        .enumerate()
                        .all(|(k, c)| c.offset == k as u32 * column_stride && c.size <= *column_stride);
                if !stride_ok {
                    let offsets: Vec<u32> = cols.iter().map(|c| c.offset).collect();
                    return Err(mismatch(format!(
                        "offset {}, columns at relative offsets {offsets:?} (host: {columns} columns {column_stride} bytes apart)",
                        member.offset
                    )));
                }
            }
            (Shape::Numeric(host_scalar), BlockType::Numeric { scalar, components }) => {
                // A 64-bit integer as two 32-bit words (WGSL has no 64-bit integers).
                let split_u64 = host_scalar.bits == 64
                    && host_scalar.kind != ScalarKind::Float
                    && scalar.kind != ScalarKind::Float
                    && scalar.bits == 32
                    && *components == 2;
                if (host_scalar != scalar && !split_u64) || member.size > field.size {
                    let what = if *components == 1 {
                        scalar.to_string()
                    } else {
                        format!("vector of {components} × {scalar}")
                    };
                    return Err(mismatch(format!(
                        "offset {}, size {}, a {what} (the host field holds {host_scalar} components)",
                        member.offset, member.size
                    )));
                }
            }
            // Handles are structs on some targets: only where they are and their size matter.
            (Shape::Plain | Shape::Numeric(_) | Shape::Buffer | Shape::Texture | Shape::Traversable, _) => {
                if member.size > field.size {
                    return Err(mismatch(format!("offset {}, size {}", member.offset, member.size)));
                }
            }
            (_, other) => return Err(mismatch(format!("offset {}, a {}", member.offset, kind_name(other)))),
        }
    }
    if let Some((index, extra)) =
        members.iter().enumerate().find(|(_, m)| !host.fields.iter().any(|f| f.offset == m.offset))
    {
        return Err(Mismatch {
            field: at(extra.name.as_deref().unwrap_or("(unnamed)")),
            host: format!(
                "absent: `{}` has only {} fields, none at offset {}",
                host.name,
                host.fields.len(),
                extra.offset
            ),
            device: format!("{} at offset {}, size {}", member_label(extra, index), extra.offset, extra.size),
            depth,
        });
    }
    Ok(())
}

fn kind_name(ty: &BlockType) -> &'static str {
    match ty {
        BlockType::Plain(_) | BlockType::Numeric { .. } => "scalar or vector",
        BlockType::Matrix { .. } => "matrix",
        BlockType::Array { .. } => "array",
        BlockType::Struct(_) => "struct",
    }
}

/// The likely cause of a mismatch in a field of type `type_name`.
fn likely_cause(type_name: &str) -> String {
    let aligned = ["Vec3A", "Vec4", "Mat3A", "Mat4", "Quat", "UVec4", "IVec4", "Affine"];
    if let Some(t) = aligned.iter().find(|t| type_name.contains(*t)) {
        format!(
            "glam's `{t}` has a different alignment on the host (SIMD, 16 bytes) than on the SPIR-V target; \
             place it at an offset that is a multiple of 16 with explicit padding fields, or use `Vec3`/`[f32; 4]`"
        )
    } else {
        "the SPIR-V is older than its device crate (the params struct changed after, or while, the SPIR-V was \
         built: rebuild it, `cargo build` again in a project whose build script builds it, `cargo xtask \
         build-shaders` in raykit's workspace), or the host and the SPIR-V were built from different definitions, \
         or the pipeline's params type is not the one the program declares"
            .to_owned()
    }
}

/// The likely cause of a program reading its params another way than raykit delivers them.
fn delivery_cause(host: &ParamsLayout, blocks: &[ParamsBlock]) -> String {
    let raykit_ubo = ParamsDelivery::UniformBuffer { set: PARAMS_SET, binding: PARAMS_BINDING };
    let raykits_own = !blocks.is_empty()
        && blocks.iter().all(|b| b.delivery == ParamsDelivery::PushConstants || b.delivery == raykit_ubo);
    if raykits_own {
        format!(
            "the program was built for params on the other side of the {PUSH_CONSTANT_BUDGET}-byte push-constant \
             budget than `{name}`. Most often the SPIR-V is older than its device crate (the struct changed after, \
             or while, the SPIR-V was built): rebuild it, with `cargo build` again in a project whose build script \
             builds it or `cargo xtask build-shaders` in raykit's workspace. Otherwise the program belongs to \
             another params type than the pipeline's",
            name = host.name
        )
    } else {
        format!(
            "the program declares its params block by hand. Use `#[params]` in Rust programs; in GLSL declare the \
             block as `layout(push_constant)` or `layout(set = {PARAMS_SET}, binding = {PARAMS_BINDING}, scalar) \
             uniform`"
        )
    }
}

/// Checks that entry point `entry`'s params block matches the host's layout.
///
/// `blocks` are the params blocks the entry point declares; the one delivered
/// the way raykit delivers `host` (`expected`) is compared.
pub fn check(host: &ParamsLayout, entry: &str, blocks: &[ParamsBlock], expected: ParamsDelivery) -> Result<()> {
    let Some(block) = blocks.iter().find(|b| b.delivery == expected) else {
        return Err(LayoutError::Delivery {
            struct_name: host.name,
            size: host.size,
            entry: entry.to_owned(),
            expected: expected.to_string(),
            found: blocks.iter().map(|b| b.delivery.to_string()).collect::<Vec<_>>().join(" and "),
            cause: delivery_cause(host, blocks),
        });
    };
    // rust-gpu wraps the struct in a one-member block; GLSL blocks are the struct.
    let mut candidates = vec![(block.members.as_slice(), 0usize)];
    if let [BlockMember { offset: 0, ty: BlockType::Struct(inner), .. }] = block.members.as_slice() {
        candidates.push((inner.as_slice(), 0));
    }
    let mut best: Option<Mismatch> = None;
    for (members, _) in candidates.iter().rev() {
        match compare(host, members, "", 0) {
            Ok(()) => return Ok(()),
            Err(m) => {
                if best.as_ref().is_none_or(|b| m.depth > b.depth) {
                    best = Some(m);
                }
            }
        }
    }
    let m = best.unwrap_or(Mismatch { field: String::new(), host: String::new(), device: String::new(), depth: 0 });
    let type_name = field_type(host, &m.field).unwrap_or("");
    Err(LayoutError::Mismatch {
        struct_name: host.name,
        entry: entry.to_owned(),
        field: m.field,
        host: m.host,
        device: m.device,
        cause: likely_cause(type_name),
    })
}

/// The type name of the field at dotted `path`.
fn field_type(host: &ParamsLayout, path: &str) -> Option<&'static str> {
    let mut layout = host;
    let mut parts = path.split('.').peekable();
    while let Some(part) = parts.next() {
        let field = layout.fields.iter().find(|f| f.name == part)?;
        if parts.peek().is_none() {
            return Some(field.type_name);
        }
        match field.shape {
            Shape::Struct(inner) => layout = inner,
            _ => return Some(field.type_name),
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use raykit_abi::{FieldLayout, Scalar};

    const INNER: ParamsLayout = ParamsLayout {
        name: "Inner",
        size: 8,
        fields: &[
            FieldLayout { name: "a", type_name: "u32", offset: 0, size: 4, shape: Shape::Plain },
            FieldLayout { name: "b", type_name: "f32", offset: 4, size: 4, shape: Shape::Plain },
        ],
    };
    const HOST: ParamsLayout = ParamsLayout {
        name: "P",
        size: 32,
        fields: &[
            FieldLayout { name: "x", type_name: "u32", offset: 0, size: 4, shape: Shape::Plain },
            FieldLayout { name: "inner", type_name: "Inner", offset: 4, size: 8, shape: Shape::Struct(&INNER) },
            FieldLayout { name: "v", type_name: "Vec4", offset: 16, size: 16, shape: Shape::Plain },
        ],
    };

    fn plain(offset: u32, size: u32) -> BlockMember {
        BlockMember { name: None, offset, size, ty: BlockType::Plain("f".into()) }
    }

    fn block(members: Vec<BlockMember>) -> ParamsBlock {
        ParamsBlock { delivery: ParamsDelivery::PushConstants, size: 32, members }
    }

    fn inner(b_offset: u32) -> BlockMember {
        BlockMember { name: None, offset: 4, size: 8, ty: BlockType::Struct(vec![plain(0, 4), plain(b_offset, 4)]) }
    }

    #[test]
    fn agreeing_layouts_pass_flat_and_wrapped() {
        let flat = block(vec![plain(0, 4), inner(4), plain(16, 16)]);
        assert!(check(&HOST, "e", std::slice::from_ref(&flat), ParamsDelivery::PushConstants).is_ok());
        let wrapped =
            block(vec![BlockMember { name: None, offset: 0, size: 32, ty: BlockType::Struct(flat.members.clone()) }]);
        assert!(check(&HOST, "e", std::slice::from_ref(&wrapped), ParamsDelivery::PushConstants).is_ok());
    }

    #[test]
    fn a_moved_field_is_named_with_both_offsets_and_the_cause() {
        let err = check(
            &HOST,
            "__raygen__rg",
            &[block(vec![plain(0, 4), inner(4), plain(12, 16)])],
            ParamsDelivery::PushConstants,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("`P`") && err.contains("`v`") && err.contains("offset 16") && err.contains("offset 12"),
            "{err}"
        );
        assert!(err.contains("Vec4") && err.contains("alignment"), "{err}");
    }

    fn number(offset: u32, name: &str, kind: ScalarKind) -> BlockMember {
        BlockMember {
            name: Some(name.to_owned()),
            offset,
            size: 4,
            ty: BlockType::Numeric { scalar: Scalar { kind, bits: 32 }, components: 1 },
        }
    }

    const SAMPLES: ParamsLayout = ParamsLayout {
        name: "Settings",
        size: 8,
        fields: &[
            FieldLayout {
                name: "samples",
                type_name: "u32",
                offset: 0,
                size: 4,
                shape: Shape::Numeric(Scalar { kind: ScalarKind::Unsigned, bits: 32 }),
            },
            FieldLayout {
                name: "exposure",
                type_name: "f32",
                offset: 4,
                size: 4,
                shape: Shape::Numeric(Scalar { kind: ScalarKind::Float, bits: 32 }),
            },
        ],
    };

    #[test]
    fn swapped_fields_of_one_size_are_told_apart_by_their_kind() {
        let device = block(vec![number(0, "exposure", ScalarKind::Float), number(4, "samples", ScalarKind::Unsigned)]);
        let err = check(&SAMPLES, "__raygen__rg", &[device], ParamsDelivery::PushConstants).unwrap_err().to_string();
        assert!(err.contains("`samples`") && err.contains("SPIR-V member 0 `exposure`"), "{err}");
        assert!(err.contains("a f32") && err.contains("holds u32"), "{err}");
        let same = block(vec![number(0, "samples", ScalarKind::Unsigned), number(4, "exposure", ScalarKind::Float)]);
        assert!(check(&SAMPLES, "e", &[same], ParamsDelivery::PushConstants).is_ok());
    }

    #[test]
    fn fields_are_paired_by_offset_not_position() {
        // The SPIR-V lists its members out of order: still the same layout.
        let reordered =
            block(vec![number(4, "exposure", ScalarKind::Float), number(0, "samples", ScalarKind::Unsigned)]);
        assert!(check(&SAMPLES, "e", &[reordered], ParamsDelivery::PushConstants).is_ok());
        // A member moved to offset 2: the host field at 0 is named with what the
        // SPIR-V has around it.
        let moved = block(vec![number(2, "samples", ScalarKind::Unsigned), number(4, "exposure", ScalarKind::Float)]);
        let err = check(&SAMPLES, "e", &[moved], ParamsDelivery::PushConstants).unwrap_err().to_string();
        assert!(err.contains("`samples`") && err.contains("SPIR-V member 0 `samples`: offset 2"), "{err}");
    }

    #[test]
    fn nested_fields_are_compared_too() {
        let err =
            check(&HOST, "e", &[block(vec![plain(0, 4), inner(8), plain(16, 16)])], ParamsDelivery::PushConstants)
                .unwrap_err()
                .to_string();
        assert!(err.contains("inner.b"), "{err}");
    }

    #[test]
    fn missing_and_extra_members_and_delivery_are_reported() {
        let err = check(&HOST, "e", &[block(vec![plain(0, 4), inner(4)])], ParamsDelivery::PushConstants)
            .unwrap_err()
            .to_string();
        assert!(err.contains("`v`") && err.contains("absent"), "{err}");
        let err = check(
            &HOST,
            "e",
            &[block(vec![plain(0, 4), inner(4), plain(16, 16), plain(32, 4)])],
            ParamsDelivery::PushConstants,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("only 3 fields"), "{err}");
        let ubo = ParamsDelivery::UniformBuffer { set: PARAMS_SET, binding: PARAMS_BINDING };
        let err = check(&HOST, "e", &[block(vec![plain(0, 4), inner(4), plain(16, 16)])], ubo).unwrap_err();
        assert!(matches!(err, LayoutError::Delivery { .. }), "{err}");
        // Push constants where raykit now delivers a uniform buffer: the SPIR-V predates a change of the struct.
        assert!(err.to_string().contains("the SPIR-V is older than its device crate"), "{err}");
        let mut other = block(vec![plain(0, 4), inner(4), plain(16, 16)]);
        other.delivery = ParamsDelivery::UniformBuffer { set: 3, binding: 7 };
        let err = check(&HOST, "e", &[other], ubo).unwrap_err().to_string();
        assert!(err.contains("declares its params block by hand") && !err.contains("older"), "{err}");
    }
}
