//! The SPIR-V entry point: a `#[spirv(…)]` function whose built-ins make the stage's context,
//! whose variables hold the program's arguments, and which calls the program.

use proc_macro2::TokenStream;
use quote::{format_ident, quote, quote_spanned};
use raykit_abi::ProgramPrefix;
use syn::spanned::Spanned;
use syn::{Ident, Type};

use super::{unsuffixed, Param, Program, ProgramMacro, Role};

/// The SPIR-V side of a program: compile-time and build-time checks, and the entry point.
pub struct EntryPoint {
    pub checks: Vec<TokenStream>,
    pub wrapper: TokenStream,
}

pub fn entry_point(program: &Program) -> EntryPoint {
    let Program { stage, fn_name, entry_name, ctx_ty, .. } = program;
    let stage = *stage;
    let wrapper = format_ident!("{}", entry_name);
    let model = stage.spirv_execution_model();
    let (builtin_params, ctx_args) = builtins(stage, program.has_attributes());
    let mut variables = Variables::default();
    for p in &program.params {
        variables.bind(program, p);
    }
    let (exception_args, exception_call_param) = exception_variables(stage);
    let (depth_param, with_depth) = trace_depth(program);
    let call_args = &variables.call_args;
    let body = quote! {
        #[allow(unused_mut)]
        let mut __ctx = ::raykit_device::#ctx_ty::__new(#ctx_args, __buffers #exception_args) #with_depth;
        #fn_name(#(#call_args),*);
    };
    let call = match &variables.launch_params {
        Some(LaunchParamsVariables { name, ty, push_constants: pc, uniform: ubo }) => quote! {
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

    let wrapper_params = &variables.params;
    let (table_set, table_binding) =
        (unsuffixed(raykit_abi::BUFFER_TABLE_SET), unsuffixed(raykit_abi::BUFFER_TABLE_BINDING));
    let exception_slot_id = unsuffixed(raykit_abi::EXCEPTION_SLOT_SPEC_ID);
    let wrapper = quote! {
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
    };
    EntryPoint { checks: variables.checks, wrapper }
}

/// `#[spirv(launch_id)]` and `#[spirv(launch_size)]`.
fn launch_builtins() -> TokenStream {
    quote! {
        #[spirv(launch_id)] __launch_id: ::raykit_device::glam::UVec3,
        #[spirv(launch_size)] __launch_size: ::raykit_device::glam::UVec3,
    }
}

/// The built-ins each stage's context is made of: the entry point's parameters that
/// read them, and the arguments that make the context of them.
fn builtins(stage: ProgramPrefix, has_attributes: bool) -> (TokenStream, TokenStream) {
    match stage {
        ProgramPrefix::Raygen | ProgramPrefix::DirectCallable | ProgramPrefix::ContinuationCallable => {
            (launch_builtins(), quote! { __launch_id, __launch_size })
        }
        ProgramPrefix::Exception => (
            quote! {
                #[spirv(launch_size)] __launch_size: ::raykit_device::glam::UVec3,
                #[spirv(incoming_callable_data)] __raykit_exception: &mut ::raykit_device::exception::ExceptionDetails,
            },
            quote! { *__raykit_exception, __launch_size },
        ),
        ProgramPrefix::Miss => {
            let launch = launch_builtins();
            (
                quote! {
                    #launch
                    #[spirv(world_ray_origin)] __world_ray_origin: ::raykit_device::glam::Vec3,
                    #[spirv(world_ray_direction)] __world_ray_direction: ::raykit_device::glam::Vec3,
                },
                quote! { __launch_id, __launch_size, __world_ray_origin, __world_ray_direction },
            )
        }
        ProgramPrefix::ClosestHit | ProgramPrefix::AnyHit | ProgramPrefix::Intersection => {
            hit_builtins(stage, has_attributes)
        }
    }
}

/// [`builtins`] of closest-hit, any-hit and intersection programs.
fn hit_builtins(stage: ProgramPrefix, has_attributes: bool) -> (TokenStream, TokenStream) {
    // Vulkan has no hit kind in intersection programs (it is what they report).
    let (hit_kind_param, hit_kind) = if stage == ProgramPrefix::Intersection {
        (quote!(), quote!(0))
    } else {
        (quote! { #[spirv(hit_kind)] __hit_kind: u32, }, quote!(__hit_kind))
    };
    let launch = launch_builtins();
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
        ProgramPrefix::ClosestHit if !has_attributes => (
            quote! { #params #[spirv(hit_attribute)] __barycentrics: &mut ::raykit_device::glam::Vec2, },
            quote! { #hit, *__barycentrics },
        ),
        ProgramPrefix::ClosestHit => (params, quote! { #hit, ::raykit_device::glam::Vec2::ZERO }),
        _ => (params, hit),
    }
}

/// The two variables that may hold the `#[params]` parameter.
struct LaunchParamsVariables {
    name: Ident,
    ty: Type,
    push_constants: Ident,
    uniform: Ident,
}

/// The entry point's variables for the program's parameters, and what it passes the program.
#[derive(Default)]
struct Variables {
    /// Parameters of the entry point.
    params: Vec<TokenStream>,
    /// Arguments of its call to the program.
    call_args: Vec<TokenStream>,
    /// Items that check the program's types.
    checks: Vec<TokenStream>,
    launch_params: Option<LaunchParamsVariables>,
}

impl Variables {
    /// Adds the variable of `param`, and its argument.
    fn bind(&mut self, program: &Program, param: &Param) {
        let name = &param.name;
        match &param.role {
            Role::Context { by_ref } => {
                self.call_args.push(if *by_ref { quote!(&mut __ctx) } else { quote!(__ctx) });
            }
            Role::Params(ty) => {
                self.bind_launch_params(program, name, ty);
                self.call_args.push(quote!(#name));
            }
            Role::Record(ty) => {
                // rust-gpu 0.11 does not wrap `ShaderRecordBufferKHR` variables in a
                // `Block` struct (as Vulkan requires, and as it does for push
                // constants); a `TypedBuffer` is such a block, laid out explicitly.
                self.params.push(quote! {
                    #[spirv(shader_record_buffer)] #name: &::raykit_device::spirv_std::TypedBuffer<#ty>
                });
                self.call_args.push(quote!(::core::ops::Deref::deref(#name)));
            }
            Role::Textures(ty) => {
                let (set, binding) =
                    (unsuffixed(raykit_abi::BUFFER_TABLE_SET), unsuffixed(raykit_abi::TEXTURE_TABLE_BINDING));
                self.params.push(quote! { #[spirv(descriptor_set = #set, binding = #binding)] #name: &#ty });
                self.call_args.push(quote!(#name));
            }
            Role::SpecConstant { id, default } => {
                let (id, default) = (unsuffixed(*id), unsuffixed(*default));
                self.params.push(quote! { #[spirv(spec_constant(id = #id, default = #default))] #name: u32 });
                self.call_args.push(quote!(#name));
            }
            Role::TracePayload(ty) => {
                self.params.push(quote! { #[spirv(ray_payload)] #name: &mut #ty });
                self.call_args.push(quote!(#name));
            }
            Role::CallData(ty) => {
                self.params.push(quote! { #[spirv(callable_data)] #name: &mut #ty });
                self.call_args.push(quote!(#name));
            }
            Role::CallableData(ty) => {
                self.params.push(quote! { #[spirv(incoming_callable_data)] #name: &mut #ty });
                self.call_args.push(quote!(#name));
            }
            Role::Attributes(ty) => {
                if program.stage == ProgramPrefix::Intersection {
                    self.params.push(quote! { #[spirv(hit_attribute)] #name: &mut #ty });
                } else {
                    self.params.push(quote! { #[spirv(hit_attribute)] #name: &#ty });
                }
                self.call_args.push(quote!(#name));
            }
            Role::Payload(ty) => {
                let storage = if program.stage == ProgramPrefix::Raygen {
                    quote!(ray_payload)
                } else {
                    quote!(incoming_ray_payload)
                };
                self.params.push(quote! { #[spirv(#storage)] #name: &mut #ty });
                self.call_args.push(quote!(#name));
                if let Some(ray) = &program.args.ray {
                    self.checks.push(payload_of_ray(program, ty, ray));
                }
            }
        }
    }

    /// The `#[params]` parameter's two variables, and the checks of its type.
    fn bind_launch_params(&mut self, program: &Program, name: &Ident, ty: &Type) {
        // Push constants for small params, a uniform buffer for large ones:
        // the same rule the host applies (`uses_push_constants`), decided
        // by a constant, so only one of the two variables is used.
        let pc = format_ident!("__{}_push_constants", name);
        let ubo = format_ident!("__{}_uniform", name);
        self.params.push(quote! { #[spirv(push_constant)] #pc: &#ty });
        let (set, binding) = (unsuffixed(raykit_abi::PARAMS_SET), unsuffixed(raykit_abi::PARAMS_BINDING));
        self.params.push(quote! {
            #[spirv(uniform, descriptor_set = #set, binding = #binding)] #ubo: &#ty
        });
        // rust-gpu gives every pointer one storage class, so the program
        // is called from two branches, and the constant condition leaves
        // only one of them (and one variable in use) in the SPIR-V.
        self.launch_params =
            Some(LaunchParamsVariables { name: name.clone(), ty: ty.clone(), push_constants: pc, uniform: ubo });
        self.checks.push(quote_spanned! {ty.span()=>
            const _: () = {
                #[allow(dead_code)]
                fn __raykit_params_derive_launch_params<P: ::raykit_device::LaunchParams>() {}
                #[allow(dead_code)]
                fn __raykit_check() { __raykit_params_derive_launch_params::<#ty>() }
            };
        });
        if !program.args.skip_params_check {
            self.checks.push(params_layout_test(&program.entry_name, ty));
        }
    }
}

/// A host-side test that `cargo xtask build-shaders` runs right after building the
/// program's crate: the SPIR-V's params block must be laid out as the host lays out the struct.
fn params_layout_test(entry_name: &str, ty: &Type) -> TokenStream {
    let test_name = format_ident!("__raykit_params_layout_{}", entry_name);
    quote! {
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
    }
}

/// The function that views the payload as the ray type's.
fn payload_of_ray_fn(entry_name: &str) -> Ident {
    format_ident!("__raykit_payload_of_{}", entry_name)
}

/// The check that the incoming payload `ty` is the ray type's: this function does not
/// compile otherwise, and it is how the entry point hands the payload to `RayType::depth`.
fn payload_of_ray(program: &Program, ty: &Type, ray: &syn::Path) -> TokenStream {
    let as_ray = payload_of_ray_fn(&program.entry_name);
    quote_spanned! {ty.span()=>
        #[doc(hidden)]
        #[allow(dead_code, non_snake_case)]
        fn #as_ray(payload: &#ty) -> &<#ray as ::raykit_device::RayType>::Payload {
            payload
        }
    }
}

/// The context's trailing constructor arguments for exceptions, and the entry point's
/// parameter they need. Stages that may call callables run the exception program
/// through a hidden callable-data variable; any-hit and intersection only record.
fn exception_variables(stage: ProgramPrefix) -> (TokenStream, TokenStream) {
    let exception_args = match stage {
        ProgramPrefix::Exception => quote!(),
        ProgramPrefix::AnyHit | ProgramPrefix::Intersection => quote!(, __exception_slot),
        _ => quote!(, __exception_slot, __raykit_exception_call),
    };
    let exception_call_param = match stage {
        ProgramPrefix::Exception | ProgramPrefix::AnyHit | ProgramPrefix::Intersection => quote!(),
        _ => quote! {
            #[spirv(callable_data)] __raykit_exception_call: &mut ::raykit_device::exception::ExceptionDetails,
        },
    };
    (exception_args, exception_call_param)
}

/// The entry point's parameter for the pipeline's `max_trace_depth`, and the call that
/// gives the context its trace depth.
///
/// Miss and closest-hit programs learn their trace depth from the incoming payload
/// when their ray type carries it (`RayType::CHECK_DEPTH`), and the pipeline's
/// `max_trace_depth` from a reserved specialization constant: their traces stop there.
fn trace_depth(program: &Program) -> (TokenStream, TokenStream) {
    if !matches!(program.stage, ProgramPrefix::Miss | ProgramPrefix::ClosestHit) {
        return (quote!(), quote!());
    }
    let incoming = program.params.iter().find_map(|p| match p.role {
        Role::Payload(_) => Some(p.name.clone()),
        _ => None,
    });
    let depth = match (&program.args.ray, &incoming) {
        (Some(ray), Some(payload)) => {
            let as_ray = payload_of_ray_fn(&program.entry_name);
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
