//! The program kinds the attribute macros handle, and the parameter roles each allows.

use proc_macro2::{Span, TokenStream};
use quote::quote;
use raykit_abi::ProgramPrefix;
use syn::Ident;

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
    pub fn prefix(self) -> ProgramPrefix {
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
    /// The attribute's name, as users write it (`closest_hit`).
    pub fn macro_name(self) -> &'static str {
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
    pub fn spirv_execution_model(self) -> Ident {
        Ident::new(self.prefix().kind().execution_model().rust_gpu_attribute(), Span::call_site())
    }
    /// `::raykit_device::ProgramKind::<kind>`.
    pub fn kind(self) -> TokenStream {
        let kind = Ident::new(&format!("{:?}", self.prefix().kind()), Span::call_site());
        quote!(::raykit_device::ProgramKind::#kind)
    }
    /// The name of its context type in `raykit_device` (`ClosestHit`).
    pub fn context_type(self) -> &'static str {
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
    /// Whether it runs for a hit (and so has hit attributes).
    pub fn is_hit(self) -> bool {
        matches!(self, Stage::ClosestHit | Stage::AnyHit | Stage::Intersection)
    }
    /// Whether it is a direct or continuation callable.
    pub fn is_callable(self) -> bool {
        matches!(self, Stage::DirectCallable | Stage::ContinuationCallable)
    }
    /// Why a parameter role is not allowed in this stage, if it is not.
    pub fn refuses(self, role: &str) -> Option<String> {
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
