//! What the attribute macros know of each program kind: its attribute and context names, and the parameter roles it allows.

use proc_macro2::{Span, TokenStream};
use quote::quote;
use raykit_abi::ProgramPrefix;
use syn::Ident;

/// What the attribute macro of each program kind knows of it, beyond its OptiX prefix.
pub trait ProgramMacro: Copy {
    /// The attribute's name, as users write it (`closest_hit`).
    fn macro_name(self) -> &'static str;
    /// rust-gpu's execution-model attribute (`ray_generation`, `closest_hit`, …).
    fn spirv_execution_model(self) -> Ident;
    /// `::raykit_device::ProgramKind::<kind>`.
    fn kind_path(self) -> TokenStream;
    /// The name of its context type in `raykit_device` (`ClosestHit`).
    fn context_type(self) -> &'static str;
    /// Whether it runs for a hit (and so has hit attributes).
    fn is_hit(self) -> bool;
    /// Whether it is a direct or continuation callable.
    fn is_callable(self) -> bool;
    /// Why a parameter role is not allowed in this stage, if it is not.
    fn refuses(self, role: &str) -> Option<String>;
}

impl ProgramMacro for ProgramPrefix {
    fn macro_name(self) -> &'static str {
        match self {
            ProgramPrefix::Raygen => "raygen",
            ProgramPrefix::Miss => "miss",
            ProgramPrefix::ClosestHit => "closest_hit",
            ProgramPrefix::AnyHit => "any_hit",
            ProgramPrefix::Intersection => "intersection",
            ProgramPrefix::DirectCallable => "direct_callable",
            ProgramPrefix::ContinuationCallable => "continuation_callable",
            ProgramPrefix::Exception => "exception",
        }
    }
    fn spirv_execution_model(self) -> Ident {
        Ident::new(self.kind().execution_model().rust_gpu_attribute(), Span::call_site())
    }
    fn kind_path(self) -> TokenStream {
        let kind = Ident::new(&format!("{:?}", self.kind()), Span::call_site());
        quote!(::raykit_device::ProgramKind::#kind)
    }
    fn context_type(self) -> &'static str {
        match self {
            ProgramPrefix::Raygen => "Raygen",
            ProgramPrefix::Miss => "Miss",
            ProgramPrefix::ClosestHit => "ClosestHit",
            ProgramPrefix::AnyHit => "AnyHit",
            ProgramPrefix::Intersection => "Intersection",
            ProgramPrefix::DirectCallable => "DirectCallable",
            ProgramPrefix::ContinuationCallable => "ContinuationCallable",
            ProgramPrefix::Exception => "Exception",
        }
    }
    fn is_hit(self) -> bool {
        matches!(self, ProgramPrefix::ClosestHit | ProgramPrefix::AnyHit | ProgramPrefix::Intersection)
    }
    fn is_callable(self) -> bool {
        matches!(self, ProgramPrefix::DirectCallable | ProgramPrefix::ContinuationCallable)
    }
    fn refuses(self, role: &str) -> Option<String> {
        let name = self.macro_name();
        if self == ProgramPrefix::Exception && !matches!(role, "params" | "record") {
            return Some(
                "an #[exception] program takes its context, #[params] and #[record]; the exception is `ctx.exception_code()`"
                    .to_owned(),
            );
        }
        match role {
            "payload" if matches!(self, ProgramPrefix::Intersection) || self.is_callable() => Some(format!(
                "#[{name}] programs have no ray payload (Vulkan gives payloads to raygen, miss, closest-hit and any-hit)"
            )),
            "trace_payload" if matches!(self, ProgramPrefix::DirectCallable) => Some(
                "direct callables cannot trace rays; use #[continuation_callable] for a callable that traces".to_owned(),
            ),
            "trace_payload" if matches!(self, ProgramPrefix::AnyHit | ProgramPrefix::Intersection) => {
                Some(format!("#[{name}] programs cannot trace rays"))
            }
            "call_data" if matches!(self, ProgramPrefix::AnyHit | ProgramPrefix::Intersection) => {
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
