//! The CPU twin of a program: the same function compiled for the host, called by raykit's CPU
//! backend with an `Invocation` that carries what the SPIR-V entry point's variables and built-ins hold.

use proc_macro2::TokenStream;
use quote::{format_ident, quote};
use raykit_abi::ProgramPrefix;
use syn::Type;

use super::{Param, Program, Role};

/// The types a program receives, which the CPU backend checks before it calls it.
#[derive(Default)]
struct CpuTypes {
    params: Option<Type>,
    record: Option<Type>,
    payload: Option<Type>,
    attributes: Option<Type>,
    callable_data: Option<Type>,
}

/// The twin's locals for the program's parameters, and what it passes the program.
#[derive(Default)]
struct Arguments {
    lets: Vec<TokenStream>,
    args: Vec<TokenStream>,
    types: CpuTypes,
}

pub fn entry_point(program: &Program) -> TokenStream {
    let Program { fn_name, entry_name, .. } = program;
    let mut arguments = Arguments::default();
    for p in &program.params {
        arguments.bind(program.stage, p);
    }
    let Arguments { lets: cpu_lets, args: cpu_args, types: cpu_types } = arguments;
    let cpu_ctx = context(program);
    let cpu_wrapper = format_ident!("__cpu{}", entry_name);
    let cpu_program = program.cpu_program();
    let (cpu_params, cpu_record, cpu_payload, cpu_attributes, cpu_callable_data) = (
        type_info(&cpu_types.params),
        type_info(&cpu_types.record),
        type_info(&cpu_types.payload),
        type_info(&cpu_types.attributes),
        type_info(&cpu_types.callable_data),
    );
    quote! {
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
    }
}

/// `Some(TypeInfo::of::<T>())` or `None`.
fn type_info(ty: &Option<Type>) -> TokenStream {
    match ty {
        Some(ty) => quote!(::core::option::Option::Some(::raykit_device::cpu::TypeInfo::of::<#ty>())),
        None => quote!(::core::option::Option::None),
    }
}

impl Arguments {
    /// Adds the local that holds `param`, and its argument.
    fn bind(&mut self, stage: ProgramPrefix, param: &Param) {
        let name = &param.name;
        let storage = format_ident!("__raykit_storage_{}", name);
        let zeroed = |ty: &Type| {
            quote! {
                // Zeroed, as the backend documents: payload and callable-data
                // variables hold plain data.
                let mut #storage: #ty = unsafe { ::raykit_device::cpu::zeroed() };
                let #name: &mut #ty = &mut #storage;
            }
        };
        let types = &mut self.types;
        let lets = &mut self.lets;
        match &param.role {
            Role::Context { by_ref } => {
                self.args.push(if *by_ref { quote!(&mut __ctx) } else { quote!(__ctx) });
                return;
            }
            Role::Params(ty) => {
                types.params = Some(ty.clone());
                lets.push(quote! { let #name: &#ty = unsafe { &*(__inv.params as *const #ty) }; });
            }
            Role::Record(ty) => {
                types.record = Some(ty.clone());
                lets.push(quote! { let #name: &#ty = unsafe { &*(__inv.record as *const #ty) }; });
            }
            Role::SpecConstant { id, default } => {
                lets.push(quote! { let #name: u32 = __inv.spec_constant(#id, #default); });
            }
            Role::Textures(_) => {
                lets.push(quote! {
                    let #storage = ::raykit_device::TextureTable::__cpu(__inv.runtime);
                    let #name = &#storage;
                });
            }
            Role::TracePayload(ty) | Role::CallData(ty) => lets.push(zeroed(ty)),
            Role::Payload(ty) if stage == ProgramPrefix::Raygen => lets.push(zeroed(ty)),
            Role::Payload(ty) => {
                types.payload = Some(ty.clone());
                lets.push(quote! { let #name: &mut #ty = unsafe { &mut *(__inv.payload as *mut #ty) }; });
            }
            Role::CallableData(ty) => {
                types.callable_data = Some(ty.clone());
                lets.push(quote! { let #name: &mut #ty = unsafe { &mut *(__inv.callable_data as *mut #ty) }; });
            }
            Role::Attributes(ty) => {
                types.attributes = Some(ty.clone());
                if stage == ProgramPrefix::Intersection {
                    lets.push(quote! { let #name: &mut #ty = unsafe { &mut *(__inv.attributes as *mut #ty) }; });
                } else {
                    lets.push(quote! { let #name: &#ty = unsafe { &*(__inv.attributes as *const #ty) }; });
                }
            }
        }
        self.args.push(quote!(#name));
    }
}

/// The expression that makes the stage's context of the invocation.
fn context(program: &Program) -> TokenStream {
    let ctx_ty = &program.ctx_ty;
    match program.stage {
        ProgramPrefix::Raygen | ProgramPrefix::DirectCallable | ProgramPrefix::ContinuationCallable => quote! {
            ::raykit_device::#ctx_ty::__new(__inv.launch_index, __inv.launch_dimensions, __inv.runtime, 0, &mut __raykit_exception_call)
        },
        ProgramPrefix::Exception => quote! {
            ::raykit_device::#ctx_ty::__new(__inv.exception, __inv.launch_dimensions, __inv.runtime)
        },
        ProgramPrefix::Miss => quote! {
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
        ProgramPrefix::ClosestHit => {
            let barycentrics = if program.has_attributes() {
                quote!(::raykit_device::glam::Vec2::ZERO)
            } else {
                quote!(unsafe { __inv.barycentrics() })
            };
            quote! {
                ::raykit_device::#ctx_ty::__new(__inv.hit, #barycentrics, __inv.runtime, 0, &mut __raykit_exception_call)
                    .__with_trace_depth(__inv.depth, __inv.max_trace_depth)
            }
        }
        ProgramPrefix::AnyHit | ProgramPrefix::Intersection => quote! {
            ::raykit_device::#ctx_ty::__new(__inv.hit, __inv.runtime, 0)
        },
    }
}
