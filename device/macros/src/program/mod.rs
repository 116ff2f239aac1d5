//! The program attribute macros (`#[raygen]`, `#[miss]`, …): a program function becomes a SPIR-V
//! entry point, a CPU twin for raykit's CPU backend, and the `EntryPoint` constant that names them.

mod cpu;
mod parse;
mod spirv;
mod stage;

use proc_macro2::TokenStream;
use quote::{format_ident, quote};
use raykit_abi::ProgramPrefix;
use syn::{Ident, ItemFn};

use parse::{Args, Param, Role};
use stage::ProgramMacro;

/// An ABI number as an unsuffixed literal, as `#[spirv(...)]` attributes need.
fn unsuffixed(value: u32) -> proc_macro2::Literal {
    proc_macro2::Literal::u32_unsuffixed(value)
}

/// A parsed program function and the names its expansions share.
struct Program {
    stage: ProgramPrefix,
    args: Args,
    params: Vec<Param>,
    /// The user's function.
    fn_name: Ident,
    /// The SPIR-V entry point's name (`__raygen__<fn_name>`).
    entry_name: String,
    /// The stage's context type in `raykit_device`.
    ctx_ty: Ident,
}

impl Program {
    /// Whether the program declares its own `#[attributes]`.
    fn has_attributes(&self) -> bool {
        self.params.iter().any(|p| matches!(p.role, Role::Attributes(_)))
    }

    /// The constant that describes the CPU twin to raykit's CPU backend.
    fn cpu_program(&self) -> Ident {
        format_ident!("__RAYKIT_CPU{}", self.entry_name.to_uppercase())
    }
}

pub fn expand(stage: ProgramPrefix, attr: TokenStream, item: TokenStream) -> TokenStream {
    match try_expand(stage, attr, item) {
        Ok(tokens) => tokens,
        Err(e) => e.to_compile_error(),
    }
}

fn try_expand(stage: ProgramPrefix, attr: TokenStream, item: TokenStream) -> syn::Result<TokenStream> {
    let args = parse::parse_args(stage, attr)?;
    let mut func: ItemFn = syn::parse2(item)?;
    parse::check_signature(stage, &func)?;
    let params = parse::parse_params(stage, &mut func)?;

    let fn_name = func.sig.ident.clone();
    let entry_name = format!("{}{}", stage.as_str(), fn_name);
    let ctx_ty = format_ident!("{}", stage.context_type());
    let program = Program { stage, args, params, fn_name, entry_name, ctx_ty };

    let entry_point = entry_point_const(&program);
    let cpu_items = cpu::entry_point(&program);
    let spirv::EntryPoint { checks, wrapper } = spirv::entry_point(&program);
    Ok(quote! {
        #func

        #entry_point

        #cpu_items

        #(#checks)*

        #wrapper
    })
}

/// `pub const <NAME>: raykit_device::EntryPoint`, through which the host names the program.
fn entry_point_const(program: &Program) -> TokenStream {
    let Program { stage, fn_name, entry_name, .. } = program;
    let entry_const = format_ident!("{}", fn_name.to_string().to_uppercase(), span = fn_name.span());
    let kind = stage.kind_path();
    let cpu_program = program.cpu_program();
    let doc = format!("The entry point `{entry_name}` (a {} program), for the host.", stage.context_type());
    let ray_info = match &program.args.ray {
        Some(ray) => {
            let name = quote!(#ray).to_string().replace(' ', "");
            quote!(::core::option::Option::Some(::raykit_device::RayTypeInfo::of::<#ray>(#name)))
        }
        None => quote!(::core::option::Option::None),
    };
    quote! {
        #[doc = #doc]
        pub const #entry_const: ::raykit_device::EntryPoint = ::raykit_device::EntryPoint {
            name: #entry_name,
            kind: #kind,
            ray: #ray_info,
            #[cfg(not(target_arch = "spirv"))]
            cpu: &#cpu_program,
        };
    }
}
