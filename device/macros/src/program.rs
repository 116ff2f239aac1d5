//! Parsing a program function and emitting its entry point.

use proc_macro2::{Span, TokenStream};
use quote::{format_ident, quote, quote_spanned};
use raykit_abi::ProgramPrefix;
use syn::spanned::Spanned;
use syn::{FnArg, Ident, ItemFn, Pat, Type};

/// An ABI number as an unsuffixed literal, as `#[spirv(...)]` attributes need.
fn unsuffixed(value: u32) -> proc_macro2::Literal {
    proc_macro2::Literal::u32_unsuffixed(value)
}

/// The program kinds these macros handle.
#[derive(Copy, Clone, PartialEq, Eq)]
pub enum Stage {
    Raygen,
    Miss,
    ClosestHit,
    AnyHit,
    Intersection,
    DirectCallable,
    ContinuationCallable,
    Exception,
}

impl Stage {
    /// The OptiX prefix of its entry point, which also gives its kind and stage.
    fn prefix(self) -> ProgramPrefix {
        match self {
            Stage::Raygen => ProgramPrefix::Raygen,
            Stage::Miss => ProgramPrefix::Miss,
            Stage::ClosestHit => ProgramPrefix::ClosestHit,
            Stage::AnyHit => ProgramPrefix::AnyHit,
            Stage::Intersection => ProgramPrefix::Intersection,
            Stage::DirectCallable => ProgramPrefix::DirectCallable,
            Stage::ContinuationCallable => ProgramPrefix::ContinuationCallable,
            Stage::Exception => ProgramPrefix::Exception,
        }
    }
    fn macro_name(self) -> &'static str {
        match self {
            Stage::Raygen => "raygen",
            Stage::Miss => "miss",
            Stage::ClosestHit => "closest_hit",
            Stage::AnyHit => "any_hit",
            Stage::Intersection => "intersection",
            Stage::DirectCallable => "direct_callable",
            Stage::ContinuationCallable => "continuation_callable",
            Stage::Exception => "exception",
        }
    }
    /// rust-gpu's execution-model attribute (`ray_generation`, `closest_hit`, …).
    fn spirv_execution_model(self) -> Ident {
        Ident::new(self.prefix().kind().execution_model().rust_gpu_attribute(), Span::call_site())
    }
    /// `::raykit_device::ProgramKind::<kind>`.
    fn kind(self) -> TokenStream {
        let kind = Ident::new(&format!("{:?}", self.prefix().kind()), Span::call_site());
        quote!(::raykit_device::ProgramKind::#kind)
    }
    fn context_type(self) -> &'static str {
        match self {
            Stage::Raygen => "Raygen",
            Stage::Miss => "Miss",
            Stage::ClosestHit => "ClosestHit",
            Stage::AnyHit => "AnyHit",
            Stage::Intersection => "Intersection",
            Stage::DirectCallable => "DirectCallable",
            Stage::ContinuationCallable => "ContinuationCallable",
            Stage::Exception => "Exception",
        }
    }
    fn is_hit(self) -> bool {
        matches!(self, Stage::ClosestHit | Stage::AnyHit | Stage::Intersection)
    }
    fn is_callable(self) -> bool {
        matches!(self, Stage::DirectCallable | Stage::ContinuationCallable)
    }
    /// Why a parameter role is not allowed in this stage, if it is not.
    fn refuses(self, role: &str) -> Option<String> {
        let name = self.macro_name();
        if self == Stage::Exception && !matches!(role, "params" | "record") {
            return Some(
                "an #[exception] program takes its context, #[params] and #[record]; the exception is `ctx.exception_code()`"
                    .to_owned(),
            );
        }
        match role {
            "payload" if matches!(self, Stage::Intersection) || self.is_callable() => Some(format!(
                "#[{name}] programs have no ray payload (Vulkan gives payloads to raygen, miss, closest-hit and any-hit)"
            )),
            "trace_payload" if matches!(self, Stage::DirectCallable) => Some(
                "direct callables cannot trace rays; use #[continuation_callable] for a callable that traces".to_owned(),
            ),
            "trace_payload" if matches!(self, Stage::AnyHit | Stage::Intersection) => {
                Some(format!("#[{name}] programs cannot trace rays"))
            }
            "call_data" if matches!(self, Stage::AnyHit | Stage::Intersection) => {
                Some(format!("#[{name}] programs cannot call callables"))
            }
            "callable_data" if !self.is_callable() => {
                Some("#[callable_data] is the incoming data of a callable program; callers use #[call_data]".to_owned())
            }
            "attributes" if !self.is_hit() => Some(format!(
                "#[{name}] programs have no hit attributes (only intersection, any-hit and closest-hit do)"
            )),
            _ => None,
        }
    }
}

/// The role of one parameter of the user's function.
enum Role {
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

/// The types a program receives, which the CPU backend checks before it calls it.
#[derive(Default)]
struct CpuTypes {
    params: Option<Type>,
    record: Option<Type>,
    payload: Option<Type>,
    attributes: Option<Type>,
    callable_data: Option<Type>,
}

struct Param {
    name: Ident,
    role: Role,
}

/// The macro's arguments: `ray = Type`, `skip_params_check`.
struct Args {
    ray: Option<syn::Path>,
    /// Generate no build-time params layout test (for tests of the check itself).
    skip_params_check: bool,
}

fn parse_args(stage: Stage, attr: TokenStream) -> syn::Result<Args> {
    let mut args = Args { ray: None, skip_params_check: false };
    if attr.is_empty() {
        return Ok(args);
    }
    let parser = syn::meta::parser(|meta| {
        if meta.path.is_ident("skip_params_check") {
            args.skip_params_check = true;
            Ok(())
        } else if meta.path.is_ident("ray") && matches!(stage, Stage::Miss | Stage::ClosestHit | Stage::AnyHit) {
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

fn parse_params(stage: Stage, func: &mut ItemFn) -> syn::Result<Vec<Param>> {
    let mut params = Vec::new();
    let mut errors: Option<syn::Error> = None;
    let mut push_error = |e: syn::Error| match &mut errors {
        Some(all) => all.combine(e),
        None => errors = Some(e),
    };
    for input in func.sig.inputs.iter_mut() {
        let FnArg::Typed(arg) = input else {
            push_error(syn::Error::new(input.span(), "device programs are free functions, not methods"));
            continue;
        };
        let name = match &*arg.pat {
            Pat::Ident(p) => p.ident.clone(),
            Pat::Wild(w) => Ident::new("__raykit_unused", w.span()),
            other => {
                push_error(syn::Error::new(other.span(), "use a plain name for program parameters"));
                continue;
            }
        };
        let mut role_attr: Option<(String, Span)> = None;
        let mut spec: Option<(u32, u32)> = None;
        let mut kept = Vec::new();
        for attr in arg.attrs.drain(..) {
            let path = attr.path();
            if path.is_ident("spec_constant") {
                match parse_spec_constant(&attr) {
                    Ok(v) => spec = Some(v),
                    Err(e) => push_error(e),
                }
                if role_attr.is_some() {
                    push_error(syn::Error::new(attr.span(), "a parameter has at most one role attribute"));
                }
                role_attr = Some(("spec_constant".to_owned(), attr.span()));
                continue;
            }
            let known = [
                "params",
                "record",
                "payload",
                "trace_payload",
                "call_data",
                "callable_data",
                "attributes",
                "textures",
            ]
            .iter()
            .find(|k| path.is_ident(k));
            match known {
                Some(k) => {
                    if role_attr.is_some() {
                        push_error(syn::Error::new(attr.span(), "a parameter has at most one role attribute"));
                    }
                    role_attr = Some(((*k).to_owned(), attr.span()));
                }
                None => kept.push(attr),
            }
        }
        arg.attrs = kept;
        let ty = &*arg.ty;
        if let Some((role, span)) = &role_attr {
            if let Some(why) = stage.refuses(role) {
                push_error(syn::Error::new(*span, why));
                continue;
            }
        }
        let attributes_mutable = stage == Stage::Intersection;
        let role = match role_attr.as_ref().map(|(s, _)| s.as_str()) {
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
            Some("spec_constant") => match (ty, spec) {
                (Type::Path(p), Some((id, default))) if p.path.is_ident("u32") => Ok(Role::SpecConstant { id, default }),
                (_, Some(_)) => Err(syn::Error::new(
                    ty.span(),
                    "a #[spec_constant] is a `u32` (Vulkan specialization constants are 32-bit; use f32::from_bits for floats)",
                )),
                (_, None) => continue,
            },
            Some(_) => referent(ty, true, "#[payload]").map(Role::Payload),
        };
        match role {
            Ok(role) => params.push(Param { name, role }),
            Err(e) => push_error(e),
        }
    }
    let count = |f: fn(&Role) -> bool| params.iter().filter(|p| f(&p.role)).count();
    if count(|r| matches!(r, Role::Context { .. })) > 1 {
        push_error(syn::Error::new(
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
            push_error(syn::Error::new(func.sig.inputs.span(), format!("at most one {what} parameter")));
        }
    }
    if stage != Stage::Raygen && count(|r| matches!(r, Role::Payload(_))) > 1 {
        push_error(syn::Error::new(
            func.sig.inputs.span(),
            "a miss or hit program has one incoming #[payload]; declare outgoing ones as #[trace_payload]",
        ));
    }
    match errors {
        Some(e) => Err(e),
        None => Ok(params),
    }
}

fn check_signature(stage: Stage, func: &ItemFn) -> syn::Result<()> {
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

pub fn expand(stage: Stage, attr: TokenStream, item: TokenStream) -> TokenStream {
    match try_expand(stage, attr, item) {
        Ok(tokens) => tokens,
        Err(e) => e.to_compile_error(),
    }
}

fn try_expand(stage: Stage, attr: TokenStream, item: TokenStream) -> syn::Result<TokenStream> {
    let args = parse_args(stage, attr)?;
    let mut func: ItemFn = syn::parse2(item)?;
    check_signature(stage, &func)?;
    let params = parse_params(stage, &mut func)?;

    let fn_name = func.sig.ident.clone();
    let entry_name = format!("{}{}", stage.prefix().as_str(), fn_name);
    let entry_const = format_ident!("{}", fn_name.to_string().to_uppercase(), span = fn_name.span());
    let wrapper = format_ident!("{}", entry_name);
    let kind = stage.kind();
    let model = stage.spirv_execution_model();
    let ctx_ty = format_ident!("{}", stage.context_type());

    // Built-ins each stage's context is made of.
    let has_attributes = params.iter().any(|p| matches!(p.role, Role::Attributes(_)));
    let launch = quote! {
        #[spirv(launch_id)] __launch_id: ::raykit_device::glam::UVec3,
        #[spirv(launch_size)] __launch_size: ::raykit_device::glam::UVec3,
    };
    let (builtin_params, ctx_args) = match stage {
        Stage::Raygen | Stage::DirectCallable | Stage::ContinuationCallable => {
            (launch, quote! { __launch_id, __launch_size })
        }
        Stage::Exception => (
            quote! {
                #[spirv(launch_size)] __launch_size: ::raykit_device::glam::UVec3,
                #[spirv(incoming_callable_data)] __raykit_exception: &mut ::raykit_device::exception::ExceptionDetails,
            },
            quote! { *__raykit_exception, __launch_size },
        ),
        Stage::Miss => (
            quote! {
                #launch
                #[spirv(world_ray_origin)] __world_ray_origin: ::raykit_device::glam::Vec3,
                #[spirv(world_ray_direction)] __world_ray_direction: ::raykit_device::glam::Vec3,
            },
            quote! { __launch_id, __launch_size, __world_ray_origin, __world_ray_direction },
        ),
        Stage::ClosestHit | Stage::AnyHit | Stage::Intersection => {
            // Vulkan has no hit kind in intersection programs (it is what they report).
            let (hit_kind_param, hit_kind) = if stage == Stage::Intersection {
                (quote!(), quote!(0))
            } else {
                (quote! { #[spirv(hit_kind)] __hit_kind: u32, }, quote!(__hit_kind))
            };
            let params = quote! {
                #launch
                #[spirv(world_ray_origin)] __world_ray_origin: ::raykit_device::glam::Vec3,
                #[spirv(world_ray_direction)] __world_ray_direction: ::raykit_device::glam::Vec3,
                #[spirv(object_ray_origin)] __object_ray_origin: ::raykit_device::glam::Vec3,
                #[spirv(object_ray_direction)] __object_ray_direction: ::raykit_device::glam::Vec3,
                #[spirv(ray_tmin)] __ray_tmin: f32,
                #[spirv(ray_tmax)] __ray_tmax: f32,
                #[spirv(incoming_ray_flags)] __ray_flags: u32,
                #hit_kind_param
                #[spirv(primitive_id)] __primitive_id: u32,
                #[spirv(instance_id)] __instance_id: u32,
                #[spirv(instance_custom_index)] __instance_custom_index: u32,
                #[spirv(ray_geometry_index)] __geometry_index: u32,
                #[spirv(object_to_world)] __object_to_world: ::raykit_device::Matrix4x3,
                #[spirv(world_to_object)] __world_to_object: ::raykit_device::Matrix4x3,
            };
            let hit = quote! {
                ::raykit_device::stage::HitBuiltins {
                    launch_index: __launch_id,
                    launch_dimensions: __launch_size,
                    world_ray_origin: __world_ray_origin,
                    world_ray_direction: __world_ray_direction,
                    object_ray_origin: __object_ray_origin,
                    object_ray_direction: __object_ray_direction,
                    ray_tmin: __ray_tmin,
                    ray_tmax: __ray_tmax,
                    ray_flags: __ray_flags,
                    hit_kind: #hit_kind,
                    primitive_index: __primitive_id,
                    instance_id: __instance_id,
                    instance_custom_index: __instance_custom_index,
                    geometry_index: __geometry_index,
                    object_to_world: __object_to_world,
                    world_to_object: __world_to_object,
                }
            };
            match stage {
                // Triangles' barycentrics are the hit attributes unless the
                // program declares its own.
                Stage::ClosestHit if !has_attributes => (
                    quote! { #params #[spirv(hit_attribute)] __barycentrics: &mut ::raykit_device::glam::Vec2, },
                    quote! { #hit, *__barycentrics },
                ),
                Stage::ClosestHit => (params, quote! { #hit, ::raykit_device::glam::Vec2::ZERO }),
                _ => (params, hit),
            }
        }
    };

    let mut wrapper_params = Vec::new();
    let mut call_args = Vec::new();
    let mut checks = Vec::new();
    let mut params_choice = None;
    for p in &params {
        let name = &p.name;
        match &p.role {
            Role::Context { by_ref } => {
                call_args.push(if *by_ref { quote!(&mut __ctx) } else { quote!(__ctx) });
            }
            Role::Params(ty) => {
                // Push constants for small params, a uniform buffer for large ones:
                // the same rule the host applies (`uses_push_constants`), decided
                // by a constant, so only one of the two variables is used.
                let pc = format_ident!("__{}_push_constants", name);
                let ubo = format_ident!("__{}_uniform", name);
                wrapper_params.push(quote! { #[spirv(push_constant)] #pc: &#ty });
                let (set, binding) = (unsuffixed(raykit_abi::PARAMS_SET), unsuffixed(raykit_abi::PARAMS_BINDING));
                wrapper_params.push(quote! {
                    #[spirv(uniform, descriptor_set = #set, binding = #binding)] #ubo: &#ty
                });
                // rust-gpu gives every pointer one storage class, so the program
                // is called from two branches, and the constant condition leaves
                // only one of them (and one variable in use) in the SPIR-V.
                params_choice = Some((name.clone(), ty.clone(), pc, ubo));
                checks.push(quote_spanned! {ty.span()=>
                    const _: () = {
                        #[allow(dead_code)]
                        fn __raykit_params_derive_launch_params<P: ::raykit_device::LaunchParams>() {}
                        #[allow(dead_code)]
                        fn __raykit_check() { __raykit_params_derive_launch_params::<#ty>() }
                    };
                });
                if !args.skip_params_check {
                    // A host-side test that `cargo xtask build-shaders` runs right
                    // after building this crate: the SPIR-V's params block must be
                    // laid out as the host lays out the struct.
                    let test_name = format_ident!("__raykit_params_layout_{}", entry_name);
                    checks.push(quote! {
                        #[cfg(test)]
                        #[test]
                        #[allow(non_snake_case)]
                        fn #test_name() {
                            let path = ::raykit_device::__private::raykit_spirv::built_spirv_path(
                                env!("CARGO_MANIFEST_DIR"),
                                env!("CARGO_PKG_NAME"),
                            );
                            if let Err(e) = ::raykit_device::__private::raykit_spirv::check_file(
                                &path,
                                #entry_name,
                                &<#ty as ::raykit_device::LaunchParams>::LAYOUT,
                                ::raykit_device::uses_push_constants::<#ty>(),
                            ) {
                                panic!("{} (in {})", e, path.display());
                            }
                        }
                    });
                }
                call_args.push(quote!(#name));
            }
            Role::Record(ty) => {
                // rust-gpu 0.11 does not wrap `ShaderRecordBufferKHR` variables in a
                // `Block` struct (as Vulkan requires, and as it does for push
                // constants); a `TypedBuffer` is such a block, laid out explicitly.
                wrapper_params.push(quote! {
                    #[spirv(shader_record_buffer)] #name: &::raykit_device::spirv_std::TypedBuffer<#ty>
                });
                call_args.push(quote!(::core::ops::Deref::deref(#name)));
            }
            Role::Textures(ty) => {
                let (set, binding) =
                    (unsuffixed(raykit_abi::BUFFER_TABLE_SET), unsuffixed(raykit_abi::TEXTURE_TABLE_BINDING));
                wrapper_params.push(quote! { #[spirv(descriptor_set = #set, binding = #binding)] #name: &#ty });
                call_args.push(quote!(#name));
            }
            Role::SpecConstant { id, default } => {
                let (id, default) = (unsuffixed(*id), unsuffixed(*default));
                wrapper_params.push(quote! { #[spirv(spec_constant(id = #id, default = #default))] #name: u32 });
                call_args.push(quote!(#name));
            }
            Role::TracePayload(ty) => {
                wrapper_params.push(quote! { #[spirv(ray_payload)] #name: &mut #ty });
                call_args.push(quote!(#name));
            }
            Role::CallData(ty) => {
                wrapper_params.push(quote! { #[spirv(callable_data)] #name: &mut #ty });
                call_args.push(quote!(#name));
            }
            Role::CallableData(ty) => {
                wrapper_params.push(quote! { #[spirv(incoming_callable_data)] #name: &mut #ty });
                call_args.push(quote!(#name));
            }
            Role::Attributes(ty) => {
                if stage == Stage::Intersection {
                    wrapper_params.push(quote! { #[spirv(hit_attribute)] #name: &mut #ty });
                } else {
                    wrapper_params.push(quote! { #[spirv(hit_attribute)] #name: &#ty });
                }
                call_args.push(quote!(#name));
            }
            Role::Payload(ty) => {
                let storage = if stage == Stage::Raygen { quote!(ray_payload) } else { quote!(incoming_ray_payload) };
                wrapper_params.push(quote! { #[spirv(#storage)] #name: &mut #ty });
                call_args.push(quote!(#name));
                if let Some(ray) = &args.ray {
                    // The payload must be the ray type's: this function does not
                    // compile otherwise, and it is how the entry point hands the
                    // payload to `RayType::depth`.
                    let as_ray = format_ident!("__raykit_payload_of_{}", entry_name);
                    checks.push(quote_spanned! {ty.span()=>
                        #[doc(hidden)]
                        #[allow(dead_code, non_snake_case)]
                        fn #as_ray(payload: &#ty) -> &<#ray as ::raykit_device::RayType>::Payload {
                            payload
                        }
                    });
                }
            }
        }
    }

    // Stages that may call callables run the exception program through a hidden
    // callable-data variable; any-hit and intersection only record.
    let exception_args = match stage {
        Stage::Exception => quote!(),
        Stage::AnyHit | Stage::Intersection => quote!(, __exception_slot),
        _ => quote!(, __exception_slot, __raykit_exception_call),
    };
    let exception_call_param = match stage {
        Stage::Exception | Stage::AnyHit | Stage::Intersection => quote!(),
        _ => quote! {
            #[spirv(callable_data)] __raykit_exception_call: &mut ::raykit_device::exception::ExceptionDetails,
        },
    };
    // Miss and closest-hit programs learn their trace depth from the incoming
    // payload when their ray type carries it (`RayType::CHECK_DEPTH`), and the
    // pipeline's `max_trace_depth` from a reserved specialization constant: their
    // traces stop there.
    let incoming = params.iter().find_map(|p| match p.role {
        Role::Payload(_) => Some(p.name.clone()),
        _ => None,
    });
    let (depth_param, with_depth) = match stage {
        Stage::Miss | Stage::ClosestHit => {
            let depth = match (&args.ray, &incoming) {
                (Some(ray), Some(payload)) => {
                    let as_ray = format_ident!("__raykit_payload_of_{}", entry_name);
                    quote! {
                        if <#ray as ::raykit_device::RayType>::CHECK_DEPTH {
                            <#ray as ::raykit_device::RayType>::depth(#as_ray(#payload))
                        } else {
                            1
                        }
                    }
                }
                _ => quote!(1),
            };
            let id = unsuffixed(raykit_abi::MAX_TRACE_DEPTH_SPEC_ID);
            (
                quote! { #[spirv(spec_constant(id = #id, default = 4294967295))] __max_trace_depth: u32, },
                quote! { .__with_trace_depth(#depth, __max_trace_depth) },
            )
        }
        _ => (quote!(), quote!()),
    };
    let body = quote! {
        #[allow(unused_mut)]
        let mut __ctx = ::raykit_device::#ctx_ty::__new(#ctx_args, __buffers #exception_args) #with_depth;
        #fn_name(#(#call_args),*);
    };
    let call = match params_choice {
        Some((name, ty, pc, ubo)) => quote! {
            if const { ::raykit_device::uses_push_constants::<#ty>() } {
                let #name: &#ty = #pc;
                #body
            } else {
                let #name: &#ty = #ubo;
                #body
            }
        },
        None => body,
    };

    // The same program compiled for the host, called by raykit's CPU backend
    // with an `Invocation` that carries what the SPIR-V entry point's variables
    // and built-ins hold.
    let mut cpu_lets = Vec::new();
    let mut cpu_args = Vec::new();
    let mut cpu_types = CpuTypes::default();
    for p in &params {
        let name = &p.name;
        let storage = format_ident!("__raykit_storage_{}", name);
        let zeroed = |ty: &Type| {
            quote! {
                // Zeroed, as the backend documents: payload and callable-data
                // variables hold plain data.
                let mut #storage: #ty = unsafe { ::raykit_device::cpu::zeroed() };
                let #name: &mut #ty = &mut #storage;
            }
        };
        match &p.role {
            Role::Context { by_ref } => cpu_args.push(if *by_ref { quote!(&mut __ctx) } else { quote!(__ctx) }),
            Role::Params(ty) => {
                cpu_types.params = Some(ty.clone());
                cpu_lets.push(quote! { let #name: &#ty = unsafe { &*(__inv.params as *const #ty) }; });
                cpu_args.push(quote!(#name));
            }
            Role::Record(ty) => {
                cpu_types.record = Some(ty.clone());
                cpu_lets.push(quote! { let #name: &#ty = unsafe { &*(__inv.record as *const #ty) }; });
                cpu_args.push(quote!(#name));
            }
            Role::SpecConstant { id, default } => {
                cpu_lets.push(quote! { let #name: u32 = __inv.spec_constant(#id, #default); });
                cpu_args.push(quote!(#name));
            }
            Role::Textures(_) => {
                cpu_lets.push(quote! {
                    let #storage = ::raykit_device::TextureTable::__cpu(__inv.runtime);
                    let #name = &#storage;
                });
                cpu_args.push(quote!(#name));
            }
            Role::TracePayload(ty) | Role::CallData(ty) => {
                cpu_lets.push(zeroed(ty));
                cpu_args.push(quote!(#name));
            }
            Role::Payload(ty) if stage == Stage::Raygen => {
                cpu_lets.push(zeroed(ty));
                cpu_args.push(quote!(#name));
            }
            Role::Payload(ty) => {
                cpu_types.payload = Some(ty.clone());
                cpu_lets.push(quote! { let #name: &mut #ty = unsafe { &mut *(__inv.payload as *mut #ty) }; });
                cpu_args.push(quote!(#name));
            }
            Role::CallableData(ty) => {
                cpu_types.callable_data = Some(ty.clone());
                cpu_lets.push(quote! { let #name: &mut #ty = unsafe { &mut *(__inv.callable_data as *mut #ty) }; });
                cpu_args.push(quote!(#name));
            }
            Role::Attributes(ty) => {
                cpu_types.attributes = Some(ty.clone());
                if stage == Stage::Intersection {
                    cpu_lets.push(quote! { let #name: &mut #ty = unsafe { &mut *(__inv.attributes as *mut #ty) }; });
                } else {
                    cpu_lets.push(quote! { let #name: &#ty = unsafe { &*(__inv.attributes as *const #ty) }; });
                }
                cpu_args.push(quote!(#name));
            }
        }
    }
    let cpu_ctx = match stage {
        Stage::Raygen | Stage::DirectCallable | Stage::ContinuationCallable => quote! {
            ::raykit_device::#ctx_ty::__new(__inv.launch_index, __inv.launch_dimensions, __inv.runtime, 0, &mut __raykit_exception_call)
        },
        Stage::Exception => quote! {
            ::raykit_device::#ctx_ty::__new(__inv.exception, __inv.launch_dimensions, __inv.runtime)
        },
        Stage::Miss => quote! {
            ::raykit_device::#ctx_ty::__new(
                __inv.launch_index,
                __inv.launch_dimensions,
                __inv.world_ray_origin,
                __inv.world_ray_direction,
                __inv.runtime,
                0,
                &mut __raykit_exception_call,
            )
            .__with_trace_depth(__inv.depth, __inv.max_trace_depth)
        },
        Stage::ClosestHit => {
            let barycentrics = if has_attributes {
                quote!(::raykit_device::glam::Vec2::ZERO)
            } else {
                quote!(unsafe { __inv.barycentrics() })
            };
            quote! {
                ::raykit_device::#ctx_ty::__new(*__inv.hit, #barycentrics, __inv.runtime, 0, &mut __raykit_exception_call)
                    .__with_trace_depth(__inv.depth, __inv.max_trace_depth)
            }
        }
        Stage::AnyHit | Stage::Intersection => quote! {
            ::raykit_device::#ctx_ty::__new(*__inv.hit, __inv.runtime, 0)
        },
    };
    let cpu_wrapper = format_ident!("__cpu{}", entry_name);
    let cpu_program = format_ident!("__RAYKIT_CPU{}", entry_name.to_uppercase());
    let type_info = |ty: &Option<Type>| match ty {
        Some(ty) => quote!(::core::option::Option::Some(::raykit_device::cpu::TypeInfo::of::<#ty>())),
        None => quote!(::core::option::Option::None),
    };
    let (cpu_params, cpu_record, cpu_payload, cpu_attributes, cpu_callable_data) = (
        type_info(&cpu_types.params),
        type_info(&cpu_types.record),
        type_info(&cpu_types.payload),
        type_info(&cpu_types.attributes),
        type_info(&cpu_types.callable_data),
    );
    let cpu_items = quote! {
        #[cfg(not(target_arch = "spirv"))]
        #[doc(hidden)]
        #[allow(non_snake_case, unused_mut, unused_variables, clippy::undocumented_unsafe_blocks)]
        // SAFETY (of the casts): raykit's CPU backend hands this function only
        // values of the types `#cpu_program` names, aligned for them.
        pub fn #cpu_wrapper(__inv: &mut ::raykit_device::cpu::Invocation<'_>) {
            let mut __raykit_exception_call = ::raykit_device::exception::ExceptionDetails::default();
            #(#cpu_lets)*
            let mut __ctx = #cpu_ctx;
            #fn_name(#(#cpu_args),*);
        }

        #[cfg(not(target_arch = "spirv"))]
        #[doc(hidden)]
        #[allow(non_upper_case_globals)]
        pub const #cpu_program: ::raykit_device::cpu::CpuProgram = ::raykit_device::cpu::CpuProgram {
            run: #cpu_wrapper,
            name: #entry_name,
            crate_name: env!("CARGO_PKG_NAME"),
            params: #cpu_params,
            record: #cpu_record,
            payload: #cpu_payload,
            attributes: #cpu_attributes,
            callable_data: #cpu_callable_data,
        };
    };

    let doc = format!("The entry point `{entry_name}` (a {} program), for the host.", stage.context_type());
    let ray_info = match &args.ray {
        Some(ray) => {
            let name = quote!(#ray).to_string().replace(' ', "");
            quote!(::core::option::Option::Some(::raykit_device::RayTypeInfo::of::<#ray>(#name)))
        }
        None => quote!(::core::option::Option::None),
    };
    let (table_set, table_binding) =
        (unsuffixed(raykit_abi::BUFFER_TABLE_SET), unsuffixed(raykit_abi::BUFFER_TABLE_BINDING));
    let exception_slot_id = unsuffixed(raykit_abi::EXCEPTION_SLOT_SPEC_ID);
    Ok(quote! {
        #func

        #[doc = #doc]
        pub const #entry_const: ::raykit_device::EntryPoint = ::raykit_device::EntryPoint {
            name: #entry_name,
            kind: #kind,
            ray: #ray_info,
            #[cfg(not(target_arch = "spirv"))]
            cpu: &#cpu_program,
        };

        #cpu_items

        #(#checks)*

        #[cfg(target_arch = "spirv")]
        #[doc(hidden)]
        #[allow(non_snake_case, clippy::too_many_arguments)]
        #[::raykit_device::__private::spirv(#model(entry_point_name = #entry_name))]
        pub fn #wrapper(
            #builtin_params
            #[spirv(descriptor_set = #table_set, binding = #table_binding, storage_buffer)]
            __buffers: &mut ::raykit_device::BufferTable,
            // The exception buffer's slot (`raykit_device::exception::EXCEPTION_SLOT_SPEC_ID`).
            #[spirv(spec_constant(id = #exception_slot_id, default = 0))] __exception_slot: u32,
            #exception_call_param
            #depth_param
            #(#wrapper_params,)*
        ) {
            #call
        }
    })
}
