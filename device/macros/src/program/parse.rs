//! Reading a program function: the macro's arguments, its signature and the role of each parameter.

use proc_macro2::{Span, TokenStream};
use raykit_abi::ProgramPrefix;
use syn::spanned::Spanned;
use syn::{FnArg, Ident, ItemFn, Pat, PatType, Type};

use super::ProgramMacro;

/// The role of one parameter of the user's function.
pub enum Role {
    Context {
        by_ref: bool,
    },
    Params(Type),
    Record(Type),
    /// Incoming payload (miss, hit) or, in raygen, an outgoing one.
    Payload(Type),
    /// An outgoing payload for `trace` in a non-raygen stage.
    TracePayload(Type),
    /// Outgoing callable data, for `call`.
    CallData(Type),
    /// A callable's incoming data.
    CallableData(Type),
    /// Hit attributes: written by intersection, read by any-hit and closest-hit.
    Attributes(Type),
    /// The bindless texture table (`&raykit_device::TextureTable`).
    Textures(Type),
    /// A specialization constant (`u32`), set per pipeline by the host.
    SpecConstant {
        id: u32,
        default: u32,
    },
}

/// One parameter of the user's function: its name and role.
pub struct Param {
    pub name: Ident,
    pub role: Role,
}

/// The macro's arguments: `ray = Type`, `skip_params_check`.
pub struct Args {
    pub ray: Option<syn::Path>,
    /// Generate no build-time params layout test (for tests of the check itself).
    pub skip_params_check: bool,
}

/// The role attributes other than `#[spec_constant(…)]`, which takes arguments.
const ROLE_ATTRIBUTES: [&str; 8] =
    ["params", "record", "payload", "trace_payload", "call_data", "callable_data", "attributes", "textures"];

/// Errors gathered while parsing, reported together.
#[derive(Default)]
struct Errors(Option<syn::Error>);

impl Errors {
    fn push(&mut self, e: syn::Error) {
        match &mut self.0 {
            Some(all) => all.combine(e),
            None => self.0 = Some(e),
        }
    }

    /// `value`, unless an error was pushed.
    fn or_ok<T>(self, value: T) -> syn::Result<T> {
        match self.0 {
            Some(e) => Err(e),
            None => Ok(value),
        }
    }
}

pub fn parse_args(stage: ProgramPrefix, attr: TokenStream) -> syn::Result<Args> {
    let mut args = Args { ray: None, skip_params_check: false };
    if attr.is_empty() {
        return Ok(args);
    }
    let parser = syn::meta::parser(|meta| {
        if meta.path.is_ident("skip_params_check") {
            args.skip_params_check = true;
            Ok(())
        } else if meta.path.is_ident("ray")
            && matches!(stage, ProgramPrefix::Miss | ProgramPrefix::ClosestHit | ProgramPrefix::AnyHit)
        {
            let value: syn::Path = meta.value()?.parse()?;
            args.ray = Some(value);
            Ok(())
        } else if meta.path.is_ident("ray") {
            Err(meta.error("`ray = …` belongs on miss, closest-hit and any-hit programs (the ones with an incoming payload); raygen names the ray type at each `trace::<R>` call"))
        } else {
            Err(meta.error(format!(
                "unknown argument of #[{}]; expected `ray = RayType`, `skip_params_check` or nothing",
                stage.macro_name()
            )))
        }
    });
    syn::parse::Parser::parse2(parser, attr)?;
    Ok(args)
}

/// `#[spec_constant(id = N)]` or `#[spec_constant(id = N, default = D)]`.
fn parse_spec_constant(attr: &syn::Attribute) -> syn::Result<(u32, u32)> {
    let mut id = None;
    let mut default = 0u32;
    attr.parse_nested_meta(|meta| {
        let value: syn::LitInt = meta.value()?.parse()?;
        if meta.path.is_ident("id") {
            id = Some(value.base10_parse::<u32>()?);
            Ok(())
        } else if meta.path.is_ident("default") {
            default = value.base10_parse::<u32>()?;
            Ok(())
        } else {
            Err(meta.error("expected `id = N` or `default = D`"))
        }
    })?;
    let id = id.ok_or_else(|| syn::Error::new(attr.span(), "#[spec_constant] needs `id = N`"))?;
    if raykit_abi::is_reserved_spec_id(id) {
        return Err(syn::Error::new(
            attr.span(),
            format!("specialization constant ID {id:#010x} is reserved by raykit"),
        ));
    }
    Ok((id, default))
}

/// `&T` (shared) or `&mut T` (exclusive) → `T`.
fn referent(ty: &Type, mutable: bool, what: &str) -> syn::Result<Type> {
    match ty {
        Type::Reference(r) if r.mutability.is_some() == mutable => Ok((*r.elem).clone()),
        _ => Err(syn::Error::new(
            ty.span(),
            format!("{what} must be taken as `{}T`", if mutable { "&mut " } else { "&" }),
        )),
    }
}

/// The role attribute a parameter names.
struct RoleAttribute {
    name: &'static str,
    span: Span,
    /// `(id, default)` of a `#[spec_constant]` whose arguments parsed.
    spec_constant: Option<(u32, u32)>,
}

/// Removes raykit's role attributes from `arg`, keeping the others, and returns the one it had.
fn take_role_attribute(arg: &mut PatType, errors: &mut Errors) -> Option<RoleAttribute> {
    let mut role: Option<(&'static str, Span)> = None;
    let mut spec_constant: Option<(u32, u32)> = None;
    let mut kept = Vec::new();
    for attr in arg.attrs.drain(..) {
        let path = attr.path();
        let name = if path.is_ident("spec_constant") {
            match parse_spec_constant(&attr) {
                Ok(v) => spec_constant = Some(v),
                Err(e) => errors.push(e),
            }
            "spec_constant"
        } else if let Some(name) = ROLE_ATTRIBUTES.into_iter().find(|k| path.is_ident(k)) {
            name
        } else {
            kept.push(attr);
            continue;
        };
        if role.is_some() {
            errors.push(syn::Error::new(attr.span(), "a parameter has at most one role attribute"));
        }
        role = Some((name, attr.span()));
    }
    arg.attrs = kept;
    role.map(|(name, span)| RoleAttribute { name, span, spec_constant })
}

/// The role a parameter of type `ty` has in `stage`, given its role attribute;
/// `None` for a `#[spec_constant]` whose arguments did not parse (already reported).
fn role_of(stage: ProgramPrefix, ty: &Type, attribute: Option<&RoleAttribute>) -> Option<syn::Result<Role>> {
    let attributes_mutable = stage == ProgramPrefix::Intersection;
    let role = match attribute.map(|a| a.name) {
        None => {
            let by_ref = matches!(ty, Type::Reference(_));
            Ok(Role::Context { by_ref })
        }
        Some("params") => referent(ty, false, "#[params]").map(Role::Params),
        Some("record") => referent(ty, false, "#[record]").map(Role::Record),
        Some("textures") => referent(ty, false, "#[textures]").map(Role::Textures),
        Some("trace_payload") => referent(ty, true, "#[trace_payload]").map(Role::TracePayload),
        Some("call_data") => referent(ty, true, "#[call_data]").map(Role::CallData),
        Some("callable_data") => referent(ty, true, "#[callable_data]").map(Role::CallableData),
        Some("attributes") if attributes_mutable => {
            referent(ty, true, "#[attributes] of an intersection program").map(Role::Attributes)
        }
        Some("attributes") => referent(ty, false, "#[attributes] of a hit program").map(Role::Attributes),
        Some("spec_constant") => match (ty, attribute.and_then(|a| a.spec_constant)) {
            (Type::Path(p), Some((id, default))) if p.path.is_ident("u32") => Ok(Role::SpecConstant { id, default }),
            (_, Some(_)) => Err(syn::Error::new(
                ty.span(),
                "a #[spec_constant] is a `u32` (Vulkan specialization constants are 32-bit; use f32::from_bits for floats)",
            )),
            (_, None) => return None,
        },
        Some(_) => referent(ty, true, "#[payload]").map(Role::Payload),
    };
    Some(role)
}

/// The parameter `input` of a program of `stage`, with its role attributes removed;
/// `None` where it has an error, which goes to `errors`.
fn parse_param(stage: ProgramPrefix, input: &mut FnArg, errors: &mut Errors) -> Option<Param> {
    let FnArg::Typed(arg) = input else {
        errors.push(syn::Error::new(input.span(), "device programs are free functions, not methods"));
        return None;
    };
    let name = match &*arg.pat {
        Pat::Ident(p) => p.ident.clone(),
        Pat::Wild(w) => Ident::new("__raykit_unused", w.span()),
        other => {
            errors.push(syn::Error::new(other.span(), "use a plain name for program parameters"));
            return None;
        }
    };
    let attribute = take_role_attribute(arg, errors);
    if let Some(attribute) = &attribute {
        if let Some(why) = stage.refuses(attribute.name) {
            errors.push(syn::Error::new(attribute.span, why));
            return None;
        }
    }
    match role_of(stage, &arg.ty, attribute.as_ref())? {
        Ok(role) => Some(Param { name, role }),
        Err(e) => {
            errors.push(e);
            None
        }
    }
}

/// Reports roles that appear more often than a program of `stage` allows.
fn check_role_counts(stage: ProgramPrefix, func: &ItemFn, params: &[Param], errors: &mut Errors) {
    let count = |f: fn(&Role) -> bool| params.iter().filter(|p| f(&p.role)).count();
    if count(|r| matches!(r, Role::Context { .. })) > 1 {
        errors.push(syn::Error::new(
            func.sig.inputs.span(),
            format!(
                "only one parameter may be the stage context (`&mut {}`); mark the others #[params], #[record] or #[payload]",
                stage.context_type()
            ),
        ));
    }
    for (what, n) in [
        ("#[params]", count(|r| matches!(r, Role::Params(_)))),
        ("#[record]", count(|r| matches!(r, Role::Record(_)))),
        ("#[callable_data]", count(|r| matches!(r, Role::CallableData(_)))),
        ("#[attributes]", count(|r| matches!(r, Role::Attributes(_)))),
        ("#[textures]", count(|r| matches!(r, Role::Textures(_)))),
    ] {
        if n > 1 {
            errors.push(syn::Error::new(func.sig.inputs.span(), format!("at most one {what} parameter")));
        }
    }
    if stage != ProgramPrefix::Raygen && count(|r| matches!(r, Role::Payload(_))) > 1 {
        errors.push(syn::Error::new(
            func.sig.inputs.span(),
            "a miss or hit program has one incoming #[payload]; declare outgoing ones as #[trace_payload]",
        ));
    }
}

/// The parameters of `func` with their roles; removes raykit's role attributes from it.
pub fn parse_params(stage: ProgramPrefix, func: &mut ItemFn) -> syn::Result<Vec<Param>> {
    let mut errors = Errors::default();
    let params: Vec<Param> =
        func.sig.inputs.iter_mut().filter_map(|input| parse_param(stage, input, &mut errors)).collect();
    check_role_counts(stage, func, &params, &mut errors);
    errors.or_ok(params)
}

/// Refuses generic, async and value-returning functions.
pub fn check_signature(stage: ProgramPrefix, func: &ItemFn) -> syn::Result<()> {
    let sig = &func.sig;
    if !sig.generics.params.is_empty() {
        return Err(syn::Error::new(
            sig.generics.span(),
            "device programs cannot be generic (each is one SPIR-V entry point)",
        ));
    }
    if let Some(a) = &sig.asyncness {
        return Err(syn::Error::new(a.span(), "device programs cannot be async"));
    }
    if let syn::ReturnType::Type(_, ty) = &sig.output {
        return Err(syn::Error::new(
            ty.span(),
            format!(
                "a #[{}] program returns nothing; write results through the payload or a buffer",
                stage.macro_name()
            ),
        ));
    }
    Ok(())
}
