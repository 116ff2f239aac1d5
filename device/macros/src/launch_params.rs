//! `#[derive(LaunchParams)]`: records a params struct's layout and refuses
//! fields that cannot cross to the device. `#[derive(SbtRecordData)]` records an
//! SBT record data struct's layout the same way.

use proc_macro2::TokenStream;
use quote::{quote, quote_spanned};
use syn::spanned::Spanned;
use syn::{Data, DeriveInput, Fields, Type};

pub fn derive(input: TokenStream) -> TokenStream {
    match try_derive(input) {
        Ok(t) => t,
        Err(e) => e.to_compile_error(),
    }
}

/// `#[derive(SbtRecordData)]`.
pub fn derive_record(input: TokenStream) -> TokenStream {
    match try_derive_record(input) {
        Ok(t) => t,
        Err(e) => e.to_compile_error(),
    }
}

/// What a derive is for, in its messages.
#[derive(Copy, Clone)]
enum Kind {
    Params,
    Record,
}

impl Kind {
    fn what(self) -> &'static str {
        match self {
            Kind::Params => "launch params",
            Kind::Record => "SBT record data",
        }
    }

    /// "need" or "needs", after [`Kind::what`].
    fn need(self) -> &'static str {
        match self {
            Kind::Params => "need",
            Kind::Record => "needs",
        }
    }

    /// Why the struct may have no padding.
    fn no_padding(self) -> &'static str {
        match self {
            Kind::Params => "launch params are `Pod` and may have none",
            Kind::Record => "SBT record data may have none (its bytes cross to the device as they are)",
        }
    }
}

pub(crate) fn has_repr_c(input: &DeriveInput) -> bool {
    input.attrs.iter().filter(|a| a.path().is_ident("repr")).any(|a| {
        let mut c = false;
        let _ = a.parse_nested_meta(|meta| {
            if meta.path.is_ident("C") {
                c = true;
            }
            // Accept and skip `align(N)` / `packed` arguments.
            if meta.input.peek(syn::token::Paren) {
                let _content;
                syn::parenthesized!(_content in meta.input);
            }
            Ok(())
        });
        c
    })
}

/// Why a field type cannot be part of launch params, if it cannot.
pub(crate) fn refuse(ty: &Type) -> Option<String> {
    match ty {
        Type::Reference(_) => Some("references cannot cross to the device; use a `Buffer<T>` handle".to_owned()),
        Type::Ptr(_) => Some("pointers cannot cross to the device; use a `Buffer<T>` handle".to_owned()),
        Type::Path(p) if p.qself.is_none() => {
            let last = p.path.segments.last()?.ident.to_string();
            match last.as_str() {
                "bool" => Some("`bool` has no defined layout on the device; use `u32` (0 or 1)".to_owned()),
                "usize" | "isize" => {
                    Some(format!("`{last}` is 8 bytes on the host and 4 on SPIR-V; use `u32`/`i32` or `u64`/`i64`"))
                }
                "char" => Some("`char` cannot cross to the device; use `u32`".to_owned()),
                _ => None,
            }
        }
        Type::Array(a) => refuse(&a.elem),
        Type::Tuple(t) if !t.elems.is_empty() => {
            Some("tuples have no defined layout; use a `#[repr(C)]` struct".to_owned())
        }
        Type::Slice(_) | Type::TraitObject(_) | Type::ImplTrait(_) => {
            Some("unsized types cannot be params fields".to_owned())
        }
        _ => None,
    }
}

/// The layout of a struct: its padding checks and its `FieldLayout` entries.
struct Layout {
    padding_checks: Vec<TokenStream>,
    entries: Vec<TokenStream>,
}

fn layout(input: &DeriveInput, kind: Kind) -> syn::Result<Layout> {
    let (what, need, no_padding) = (kind.what(), kind.need(), kind.no_padding());
    let name = &input.ident;
    if !input.generics.params.is_empty() {
        return Err(syn::Error::new(input.generics.span(), format!("{what} cannot be generic")));
    }
    let Data::Struct(data) = &input.data else {
        return Err(syn::Error::new(input.span(), format!("{what} must be a struct")));
    };
    if !has_repr_c(input) {
        return Err(syn::Error::new(
            name.span(),
            format!("{what} {need} `#[repr(C)]`, so host and device lay the fields out by the same rules"),
        ));
    }
    let Fields::Named(fields) = &data.fields else {
        return Err(syn::Error::new(data.fields.span(), format!("{what} {need} named fields")));
    };
    let mut errors: Option<syn::Error> = None;
    let mut entries = Vec::new();
    let mut padding_checks = Vec::new();
    let named: Vec<(&syn::Ident, &syn::Type)> =
        fields.named.iter().filter_map(|f| f.ident.as_ref().map(|i| (i, &f.ty))).collect();
    // Padding named by field, before bytemuck's `Pod` says only "padding".
    for (k, (ident, ty)) in named.iter().enumerate() {
        let end = quote!(::core::mem::offset_of!(#name, #ident) + ::core::mem::size_of::<#ty>());
        let (next_start, message) = match named.get(k + 1) {
            Some((next, _)) => (
                quote!(::core::mem::offset_of!(#name, #next)),
                format!(
                    "`{name}` has padding after field `{ident}` (before `{next}`): {no_padding}; add an explicit padding field after `{ident}` (e.g. `_pad: u32`) or reorder the fields"
                ),
            ),
            None => (
                quote!(::core::mem::size_of::<#name>()),
                format!(
                    "`{name}` has padding after its last field `{ident}`: {no_padding}; add an explicit padding field at the end (e.g. `_pad: u32`)"
                ),
            ),
        };
        padding_checks.push(quote_spanned! {ident.span()=>
            const _: () = ::core::assert!(#end == #next_start, #message);
        });
    }
    for field in &fields.named {
        let Some(ident) = &field.ident else { continue };
        if let Some(reason) = refuse(&field.ty) {
            let e = syn::Error::new(field.ty.span(), format!("field `{ident}`: {reason}"));
            match &mut errors {
                Some(all) => all.combine(e),
                None => errors = Some(e),
            }
            continue;
        }
        let ty = &field.ty;
        let field_name = ident.to_string();
        let type_name = quote!(#ty).to_string().replace(' ', "");
        // `<T as DeviceField>` with the field's span: an unsupported type is an
        // error pointing at the field, with DeviceField's explanation.
        let shape = quote_spanned! {ty.span()=> <#ty as ::raykit_device::DeviceField>::SHAPE };
        entries.push(quote! {
            ::raykit_device::FieldLayout {
                name: #field_name,
                type_name: #type_name,
                offset: ::core::mem::offset_of!(#name, #ident) as u32,
                size: ::core::mem::size_of::<#ty>() as u32,
                shape: #shape,
            }
        });
    }
    if let Some(e) = errors {
        return Err(e);
    }
    Ok(Layout { padding_checks, entries })
}

fn try_derive(input: TokenStream) -> syn::Result<TokenStream> {
    let input: DeriveInput = syn::parse2(input)?;
    let Layout { padding_checks, entries } = layout(&input, Kind::Params)?;
    let name = &input.ident;
    let struct_name = name.to_string();
    Ok(quote! {
        #(#padding_checks)*
        impl ::raykit_device::LaunchParams for #name {
            const LAYOUT: ::raykit_device::ParamsLayout = ::raykit_device::ParamsLayout {
                name: #struct_name,
                size: ::core::mem::size_of::<#name>() as u32,
                fields: &[#(#entries),*],
            };
        }
        impl ::raykit_device::DeviceField for #name {
            const SHAPE: ::raykit_device::Shape =
                ::raykit_device::Shape::Struct(&<#name as ::raykit_device::LaunchParams>::LAYOUT);
        }
    })
}

fn try_derive_record(input: TokenStream) -> syn::Result<TokenStream> {
    let input: DeriveInput = syn::parse2(input)?;
    let Layout { padding_checks, entries } = layout(&input, Kind::Record)?;
    let name = &input.ident;
    Ok(quote! {
        #(#padding_checks)*
        // SAFETY: `#[repr(C)]` (checked by the derive), without padding (the
        // assertions above) and made of `DeviceField`s, which are `Pod` (each
        // entry below names its field's `DeviceField::SHAPE`): every byte of a
        // value is initialised.
        unsafe impl ::raykit_device::SbtRecordData for #name {
            const FIELDS: &'static [::raykit_device::FieldLayout] = &[#(#entries),*];
        }
    })
}
