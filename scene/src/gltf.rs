//! glTF 2.0 scenes (through the `gltf` crate): meshes of indexed triangles with
//! normals, texture coordinates and tangents, metallic-roughness materials with
//! their textures and alpha modes, and the node hierarchy flattened into mesh
//! instances with world transforms. What a renderer makes of it (one GAS per
//! mesh with a geometry per primitive, one instance per [`MeshInstance`]) is up
//! to the renderer.
//!
//! Bad files are [`GltfError`]s naming the problem, its place in the file as a
//! glTF path (`meshes[0].primitives[0].attributes.POSITION`) and the fix: a
//! buffer whose file is missing, a primitive that is not triangles, an index
//! past the vertices, a primitive without positions, an image format with no
//! texture format.
//!
//! Hostile files are errors too, never a panic, a hang or a stack overflow.
//! Before the `gltf` crate's readers see an accessor, the loader checks
//! ([`validate`]) every buffer view against its buffer and each accessor it
//! reads against its view: its type and component type, a count of at least
//! one, its offset, stride and last element inside the view, its sparse
//! counts and indices, index types, and that every vertex attribute has as
//! many elements as `POSITION`. The node graph is walked with an explicit stack
//! ([`nodes`]): a node that is its own ancestor is a [`GltfError::NodeCycle`],
//! a subtree shared by several parents is instanced once per path, up to
//! [`nodes::MAX_NODE_INSTANCES`] node instances in all.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec2, Vec3, Vec4};

pub mod nodes;
#[cfg(test)]
mod tests;
pub mod validate;

/// Why a glTF file could not be loaded. Each names the problem, where it is (a
/// glTF path such as `meshes[0].primitives[0].attributes.POSITION`) and the fix.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GltfError {
    /// The file could not be read or parsed.
    #[error("glTF {path}: {source}; check that the file is glTF 2.0 (.gltf or .glb)")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's error.
        source: gltf::Error,
    },
    /// An index in the file names an element past the end of its array.
    #[error("glTF {path}: {target}[{index}] does not exist, the file has {count}; fix the index")]
    DanglingIndex {
        /// Where the index is.
        path: String,
        /// The array it indexes (`accessors`, …).
        target: &'static str,
        /// The index.
        index: usize,
        /// The array's length.
        count: usize,
    },
    /// A buffer's file is missing.
    #[error("glTF {path}: buffers[{buffer}].uri refers to `{uri}`, which is not at {resolved}; put the file beside the .gltf or fix the buffer's uri")]
    MissingBuffer {
        /// The glTF file.
        path: PathBuf,
        /// The buffer's index.
        buffer: usize,
        /// Its uri.
        uri: String,
        /// Where it was looked for.
        resolved: PathBuf,
    },
    /// An image's file is missing.
    #[error("glTF {path}: images[{image}].uri refers to `{uri}`, which is not at {resolved}; put the image beside the .gltf or fix the image's uri")]
    MissingImage {
        /// The glTF file.
        path: PathBuf,
        /// The image's index.
        image: usize,
        /// Its uri.
        uri: String,
        /// Where it was looked for.
        resolved: PathBuf,
    },
    /// A buffer or image uri reaches a file outside the glTF file's folder (an
    /// absolute path, a `file:` uri, `..` or a symbolic link leading out), and
    /// [`LoadOptions::allow_outside_folder`] is off.
    #[error("glTF {path}: {reference} is `{uri}`, which resolves to {resolved}, outside the scene's folder {folder}; a glTF file reads only files in its own folder: copy the file into it and give a relative uri, or, for a file you trust, load it with `GltfScene::load_with(path, &LoadOptions {{ allow_outside_folder: true, ..Default::default() }})`")]
    OutsideFolder {
        /// The glTF file.
        path: PathBuf,
        /// The uri's place in the file (`buffers[0].uri`, `images[1].uri`).
        reference: String,
        /// The uri.
        uri: String,
        /// The file it names, symbolic links resolved.
        resolved: PathBuf,
        /// The glTF file's folder, symbolic links resolved.
        folder: PathBuf,
    },
    /// A uri whose percent-encoding does not decode to UTF-8.
    #[error("glTF {path}: {reference} is `{uri}`, whose %-escapes do not decode to UTF-8; fix the uri (escape file names as UTF-8)")]
    UriEncoding {
        /// The glTF file.
        path: PathBuf,
        /// The uri's place in the file (`buffers[0].uri`, `images[1].uri`).
        reference: String,
        /// The uri.
        uri: String,
    },
    /// A primitive is not a triangle list.
    #[error("glTF meshes[{mesh}].primitives[{primitive}].mode is {mode}; only triangles are ray traced: triangulate it in the exporter (strips and fans too)")]
    NotTriangles {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
        /// Its mode.
        mode: String,
    },
    /// A primitive has no positions.
    #[error("glTF meshes[{mesh}].primitives[{primitive}].attributes has no POSITION attribute; export the mesh with positions")]
    MissingPositions {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
    },
    /// An index names a vertex past the primitive's vertices.
    #[error("glTF meshes[{mesh}].primitives[{primitive}].indices: index {index} at position {at} names vertex {index} of {vertices}; the index buffer does not belong to these vertices (re-export the mesh)")]
    IndexOutOfRange {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
        /// The index.
        index: u32,
        /// Where it is in the index list.
        at: usize,
        /// The number of vertices.
        vertices: usize,
    },
    /// The index count is not a multiple of 3.
    #[error("glTF meshes[{mesh}].primitives[{primitive}].indices has {count} indices, not a multiple of 3; a triangle list needs 3 per triangle")]
    IndexCount {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
        /// The count.
        count: usize,
    },
    /// An image's pixel format has no texture format.
    #[error("glTF images[{image}] has pixel format {format}; save it as 8-bit (grey, RGB or RGBA) or 32-bit float")]
    ImageFormat {
        /// The image.
        image: usize,
        /// Its format.
        format: String,
    },
    /// A buffer view's bytes reach past the end of its buffer (or past 2⁶⁴).
    #[error("glTF {path}: bytes {start}..{end} of buffers[{buffer}], which has {length} bytes; fix the view's byteOffset and byteLength to lie inside the buffer")]
    ViewOutOfBounds {
        /// The view, as a glTF path (`bufferViews[2]`).
        path: String,
        /// Its buffer.
        buffer: usize,
        /// The view's first byte in the buffer.
        start: u128,
        /// One past its last byte.
        end: u128,
        /// The buffer's length.
        length: usize,
    },
    /// An accessor's type or component type is not one its use allows.
    #[error("glTF {path}: accessors[{accessor}] is {found}, but this must be {expected}; re-export the mesh with {expected}")]
    AccessorType {
        /// Where the accessor is used (`meshes[0].primitives[0].indices`).
        path: String,
        /// The accessor.
        accessor: usize,
        /// Its type and component type (`VEC2 of FLOAT`).
        found: String,
        /// What this use allows.
        expected: &'static str,
    },
    /// An accessor has no elements.
    #[error("glTF {path}: accessors[{accessor}] has count 0; an accessor holds at least one element: export the data or remove the attribute")]
    EmptyAccessor {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
    },
    /// An accessor has more elements than the loader takes.
    #[error("glTF {path}: accessors[{accessor}] has count {count}, over the limit of {limit}; split the mesh into smaller ones")]
    AccessorTooLarge {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
        /// Its count.
        count: usize,
        /// The most elements the loader takes (fewer for accessors without a buffer view, whose elements are zeros).
        limit: usize,
    },
    /// An accessor's elements reach past the end of its buffer view.
    #[error("glTF {path}: accessors[{accessor}]{part} reads bytes {start}..{end} of bufferViews[{view}], which has {length} bytes; fix its byteOffset and count, or the view's byteLength")]
    AccessorOutOfBounds {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
        /// Which part of it: empty for its elements, `.sparse.indices` or `.sparse.values`.
        part: &'static str,
        /// The view.
        view: usize,
        /// The first byte read, from the view's start.
        start: u128,
        /// One past the last byte read.
        end: u128,
        /// The view's length.
        length: usize,
    },
    /// A buffer view's stride is shorter than the elements an accessor reads through it.
    #[error("glTF {path}: accessors[{accessor}]{part} has {element}-byte elements, but bufferViews[{view}].byteStride is {stride}; make the stride at least the element size")]
    AccessorStride {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
        /// Which part of it: empty for its elements, `.sparse.indices` or `.sparse.values`.
        part: &'static str,
        /// The view.
        view: usize,
        /// The view's stride.
        stride: usize,
        /// The element size.
        element: usize,
    },
    /// An accessor has neither a buffer view nor sparse values.
    #[error(
        "glTF {path}: accessors[{accessor}] has no bufferView and no sparse values; give it a bufferView with its data"
    )]
    AccessorWithoutData {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
    },
    /// A sparse accessor's count is 0 or more than the accessor's count.
    #[error("glTF {path}: accessors[{accessor}].sparse.count is {sparse}, but the accessor has {count} elements; a sparse count is between 1 and the accessor's count (remove `sparse` if nothing is replaced)")]
    SparseCount {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
        /// The sparse count.
        sparse: usize,
        /// The accessor's count.
        count: usize,
    },
    /// A sparse index is not above the one before it, or not below the accessor's count.
    #[error("glTF {path}: accessors[{accessor}].sparse.indices[{at}] is {index}; sparse indices increase strictly and stay below the accessor's count, {count}: re-export the mesh")]
    SparseIndex {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
        /// The index's position in the sparse indices.
        at: usize,
        /// The index.
        index: u64,
        /// The index before it.
        previous: Option<u64>,
        /// The accessor's count.
        count: usize,
    },
    /// A vertex attribute has a different number of elements than `POSITION`.
    #[error("glTF {path}: accessors[{accessor}] has {count} elements, but POSITION has {positions}; every vertex attribute has one element per vertex: re-export the mesh")]
    AttributeCount {
        /// The attribute (`meshes[0].primitives[0].attributes.NORMAL`).
        path: String,
        /// Its accessor.
        accessor: usize,
        /// Its count.
        count: usize,
        /// The number of positions.
        positions: usize,
    },
    /// The `gltf` crate could not read an accessor that passed the checks.
    #[error("glTF {path}: accessors[{accessor}] could not be read ({reason}); check the file with the Khronos glTF validator")]
    UnreadableAccessor {
        /// Where the accessor is used.
        path: String,
        /// The accessor.
        accessor: usize,
        /// What went wrong.
        reason: String,
    },
    /// A node is its own ancestor.
    #[error("glTF {path}: node {child} is its own ancestor (nodes {}); the node graph must be a forest: remove the child", nodes::arrows(.cycle))]
    NodeCycle {
        /// The child entry that closes the cycle (`nodes[2].children[0]`).
        path: String,
        /// The node listed as a child.
        child: usize,
        /// The nodes of the cycle, from the repeated node down to it again.
        cycle: Vec<usize>,
    },
    /// The node graph reaches more node instances than the loader takes.
    #[error("glTF {path}: the scene reaches more than {limit} node instances (a node listed under several parents is instanced once per path); list each node as the child of one parent")]
    TooManyNodeInstances {
        /// The child entry (or scene root) past the limit.
        path: String,
        /// The limit, [`nodes::MAX_NODE_INSTANCES`].
        limit: usize,
    },
}

/// How a material's alpha is used.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored.
    Opaque,
    /// Surfaces with alpha below the cutoff are not there (any-hit programs ignore them).
    Mask(f32),
    /// Alpha blending; renderers here treat it as opaque.
    Blend,
}

/// A metallic-roughness material. Texture indices are into [`GltfScene::images`].
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name, if the file gives one.
    pub name: Option<String>,
    /// Base colour factor (linear RGBA).
    pub base_color: Vec4,
    /// Base colour texture (sRGB), with the texture coordinate set 0.
    pub base_color_texture: Option<usize>,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor (perceptual).
    pub roughness: f32,
    /// Metallic (blue) and roughness (green) texture, linear.
    pub metallic_roughness_texture: Option<usize>,
    /// Tangent-space normal map, linear.
    pub normal_texture: Option<usize>,
    /// The normal map's `scale` (multiplies the map's x and y; 1 when the file gives none).
    pub normal_scale: f32,
    /// Emissive factor (linear RGB).
    pub emissive: Vec3,
    /// `KHR_materials_emissive_strength`'s multiplier of the emission (1 without the extension).
    pub emissive_strength: f32,
    /// Emissive texture (sRGB).
    pub emissive_texture: Option<usize>,
    /// Alpha mode.
    pub alpha: AlphaMode,
}

impl Default for Material {
    /// glTF's default material: base colour white, metallic 1, roughness 1 (the
    /// specification's defaults).
    fn default() -> Self {
        Material {
            name: None,
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            emissive: Vec3::ZERO,
            emissive_strength: 1.0,
            emissive_texture: None,
            alpha: AlphaMode::Opaque,
        }
    }
}

/// One primitive: an indexed triangle list.
#[derive(Clone, Debug, PartialEq)]
pub struct Primitive {
    /// Vertex positions (object space).
    pub positions: Vec<Vec3>,
    /// Vertex normals (from the file, or the area-weighted face normals when it has none).
    pub normals: Vec<Vec3>,
    /// Texture coordinates of set 0 (zeros when the file has none).
    pub uvs: Vec<Vec2>,
    /// Tangents (xyz, w the bitangent sign); empty when the file has none.
    pub tangents: Vec<Vec4>,
    /// Three vertex indices per triangle (sequential when the file has none).
    pub indices: Vec<u32>,
    /// The material: an index into [`GltfScene::materials`] (the default material,
    /// last, for primitives without one).
    pub material: usize,
}

/// A mesh: its primitives.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Name, if the file gives one.
    pub name: Option<String>,
    /// The primitives.
    pub primitives: Vec<Primitive>,
}

/// A node with a mesh, placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshInstance {
    /// The mesh: an index into [`GltfScene::meshes`].
    pub mesh: usize,
    /// The node's index in the file.
    pub node: usize,
    /// Object to world: the product of the transforms from the scene's root down to the node.
    pub transform: Mat4,
}

/// An image, as 8-bit RGBA.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// RGBA8 texels, row-major, row 0 first (texture coordinate v = 0).
    pub rgba8: Vec<u8>,
}

/// How [`GltfScene::load_with`] reads the files a glTF file names.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Let buffer and image uris reach files outside the glTF file's folder:
    /// absolute paths, `file:` uris, `..` and symbolic links that lead out. Off
    /// by default, so that a scene from elsewhere reads nothing but its own
    /// folder (and its subfolders); turn it on only for files you trust.
    pub allow_outside_folder: bool,
}

/// A loaded glTF scene.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfScene {
    /// The meshes.
    pub meshes: Vec<Mesh>,
    /// Every node with a mesh in the default scene (or the first), with its world transform.
    pub instances: Vec<MeshInstance>,
    /// The materials, then glTF's default material.
    pub materials: Vec<Material>,
    /// The images textures refer to.
    pub images: Vec<Image>,
}

impl GltfScene {
    /// Loads `path` (.gltf with its buffers and images beside it, or .glb).
    /// Buffers and images must lie in `path`'s folder or below it
    /// ([`GltfError::OutsideFolder`]; see [`GltfScene::load_with`]).
    pub fn load(path: &Path) -> Result<GltfScene, GltfError> {
        GltfScene::load_with(path, &LoadOptions::default())
    }

    /// [`GltfScene::load`] with `options`.
    pub fn load_with(path: &Path, options: &LoadOptions) -> Result<GltfScene, GltfError> {
        let parse = |source| GltfError::Parse { path: path.to_owned(), source };
        let bytes = std::fs::read(path).map_err(|e| parse(gltf::Error::Io(e)))?;
        GltfScene::from_slice_with(&bytes, path, options)
    }

    /// Loads a glTF (JSON) or GLB file already in memory, as [`GltfScene::load`]
    /// would the file at `path`: buffers and images it names by relative URI are
    /// read beside `path` (in its folder only), and errors name `path`.
    pub fn from_slice(bytes: &[u8], path: &Path) -> Result<GltfScene, GltfError> {
        GltfScene::from_slice_with(bytes, path, &LoadOptions::default())
    }

    /// [`GltfScene::from_slice`] with `options`.
    pub fn from_slice_with(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<GltfScene, GltfError> {
        let parse = |source| GltfError::Parse { path: path.to_owned(), source };
        let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes).map_err(parse)?;
        // The `gltf` crate's validation reads the POSITION accessor before
        // checking its index: that index is checked first.
        validate::position_indices(document.as_json())?;
        let document = gltf::Document::from_json(document.into_json()).map_err(parse)?;
        let base = match path.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent,
            _ => Path::new("."),
        };
        let files = ReferencedFiles { path, base, options };
        for buffer in document.buffers() {
            if let gltf::buffer::Source::Uri(uri) = buffer.source() {
                let missing = |resolved| GltfError::MissingBuffer {
                    path: path.to_owned(),
                    buffer: buffer.index(),
                    uri: uri.to_owned(),
                    resolved,
                };
                files.check(&format!("buffers[{}].uri", buffer.index()), uri, missing)?;
            }
        }
        for image in document.images() {
            if let gltf::image::Source::Uri { uri, .. } = image.source() {
                let missing = |resolved| GltfError::MissingImage {
                    path: path.to_owned(),
                    image: image.index(),
                    uri: uri.to_owned(),
                    resolved,
                };
                files.check(&format!("images[{}].uri", image.index()), uri, missing)?;
            }
        }
        // Image views are sliced while importing: every view is checked first.
        validate::buffer_views(&document)?;
        let buffers = gltf::import_buffers(&document, Some(base), blob).map_err(parse)?;
        let images = gltf::import_images(&document, Some(base), &buffers).map_err(parse)?;

        let images =
            images.into_iter().enumerate().map(|(i, data)| to_rgba8(i, data)).collect::<Result<Vec<_>, _>>()?;
        let texture_image = |t: gltf::texture::Texture| t.source().index();
        let mut materials: Vec<Material> = document
            .materials()
            .map(|m| {
                let pbr = m.pbr_metallic_roughness();
                Material {
                    name: m.name().map(str::to_owned),
                    base_color: Vec4::from_array(pbr.base_color_factor()),
                    base_color_texture: pbr.base_color_texture().map(|t| texture_image(t.texture())),
                    metallic: pbr.metallic_factor(),
                    roughness: pbr.roughness_factor(),
                    metallic_roughness_texture: pbr.metallic_roughness_texture().map(|t| texture_image(t.texture())),
                    normal_texture: m.normal_texture().map(|t| texture_image(t.texture())),
                    normal_scale: m.normal_texture().map_or(1.0, |t| t.scale()),
                    emissive: Vec3::from_array(m.emissive_factor()),
                    emissive_strength: m.emissive_strength().unwrap_or(1.0),
                    emissive_texture: m.emissive_texture().map(|t| texture_image(t.texture())),
                    alpha: match m.alpha_mode() {
                        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                        gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
                        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
                    },
                }
            })
            .collect();
        let default_material = materials.len();
        materials.push(Material::default());

        let mut meshes = Vec::new();
        for mesh in document.meshes() {
            let mut primitives = Vec::new();
            for (primitive_index, primitive) in mesh.primitives().enumerate() {
                primitives.push(load_primitive(mesh.index(), primitive_index, &primitive, &buffers, default_material)?);
            }
            meshes.push(Mesh { name: mesh.name().map(str::to_owned), primitives });
        }

        let instances = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => nodes::instances(&document, &scene)?,
            None => Vec::new(),
        };
        Ok(GltfScene { meshes, instances, materials, images })
    }
}

/// The files a glTF file's uris name, checked before the `gltf` crate reads them.
struct ReferencedFiles<'a> {
    /// The glTF file.
    path: &'a Path,
    /// Its folder, where relative uris start.
    base: &'a Path,
    options: &'a LoadOptions,
}

impl ReferencedFiles<'_> {
    /// Checks the file `uri` (at `reference` in the glTF file) names, as the
    /// `gltf` crate resolves it: `data:` uris and other schemes (which it
    /// refuses) are left to it; a `file:` uri is a path, anything else a
    /// %-encoded path relative to the folder. The file must exist (else
    /// `missing(where it was looked for)`) and, unless
    /// [`LoadOptions::allow_outside_folder`], lie inside the folder once both
    /// are canonical (symbolic links and `..` resolved).
    fn check(&self, reference: &str, uri: &str, missing: impl FnOnce(PathBuf) -> GltfError) -> Result<(), GltfError> {
        let file = if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
            PathBuf::from(rest)
        } else if uri.contains(':') {
            return Ok(());
        } else {
            let decoded = percent_decode(uri).ok_or_else(|| GltfError::UriEncoding {
                path: self.path.to_owned(),
                reference: reference.to_owned(),
                uri: uri.to_owned(),
            })?;
            self.base.join(decoded)
        };
        let resolved = match file.canonicalize() {
            Ok(resolved) if resolved.is_file() => resolved,
            _ => return Err(missing(file)),
        };
        if self.options.allow_outside_folder {
            return Ok(());
        }
        let folder = self.base.canonicalize().unwrap_or_else(|_| self.base.to_owned());
        if resolved.starts_with(&folder) {
            return Ok(());
        }
        Err(GltfError::OutsideFolder {
            path: self.path.to_owned(),
            reference: reference.to_owned(),
            uri: uri.to_owned(),
            resolved,
            folder,
        })
    }
}

/// `uri` with its `%XX` escapes decoded, as the `gltf` crate decodes relative
/// uris; `None` where the bytes are not UTF-8 (which the `gltf` crate would
/// panic on). A `%` without two hex digits stays as it is.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex_digit = |at: usize| bytes.get(at).and_then(|&b| (b as char).to_digit(16));
        let escape = hex_digit(i + 1).zip(hex_digit(i + 2)).map(|(high, low)| (high * 16 + low) as u8);
        match (bytes[i], escape) {
            (b'%', Some(byte)) => {
                decoded.push(byte);
                i += 3;
            }
            (byte, _) => {
                decoded.push(byte);
                i += 1;
            }
        }
    }
    String::from_utf8(decoded).ok()
}

/// One primitive, its accessors checked ([`validate::accessor`]) before they are read.
fn load_primitive(
    mesh_index: usize,
    primitive_index: usize,
    primitive: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    default_material: usize,
) -> Result<Primitive, GltfError> {
    use gltf::Semantic;
    use validate::Use;
    if primitive.mode() != gltf::mesh::Mode::Triangles {
        return Err(GltfError::NotTriangles {
            mesh: mesh_index,
            primitive: primitive_index,
            mode: format!("{:?}", primitive.mode()),
        });
    }
    let place = format!("meshes[{mesh_index}].primitives[{primitive_index}]");
    let position_accessor = primitive
        .get(&Semantic::Positions)
        .ok_or(GltfError::MissingPositions { mesh: mesh_index, primitive: primitive_index })?;
    let position_path = format!("{place}.attributes.POSITION");
    let vertices = validate::accessor(&position_accessor, &position_path, Use::Position, buffers)?;
    // The other attributes read: one element per vertex each.
    let attributes =
        [(Semantic::Normals, Use::Normal), (Semantic::TexCoords(0), Use::TexCoord), (Semantic::Tangents, Use::Tangent)];
    for (semantic, usage) in attributes {
        if let Some(accessor) = primitive.get(&semantic) {
            let path = format!("{place}.attributes.{}", semantic.to_string());
            let count = validate::accessor(&accessor, &path, usage, buffers)?;
            if count != vertices {
                return Err(GltfError::AttributeCount { path, accessor: accessor.index(), count, positions: vertices });
            }
        }
    }
    let index_path = format!("{place}.indices");
    if let Some(accessor) = primitive.indices() {
        validate::accessor(&accessor, &index_path, Use::Index, buffers)?;
    }

    let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let positions: Vec<Vec3> = validate::read(&position_path, position_accessor.index(), || {
        reader.read_positions().map(|it| it.map(Vec3::from_array).collect())
    })?;
    let vertex_count = positions.len();
    let indices: Vec<u32> = match primitive.indices() {
        Some(accessor) => {
            validate::read(&index_path, accessor.index(), || reader.read_indices().map(|i| i.into_u32().collect()))?
        }
        // `validate::accessor` caps counts at `u32::MAX`.
        None => (0..vertex_count as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(GltfError::IndexCount { mesh: mesh_index, primitive: primitive_index, count: indices.len() });
    }
    if let Some((at, &index)) = indices.iter().enumerate().find(|(_, &i)| i as usize >= vertex_count) {
        return Err(GltfError::IndexOutOfRange {
            mesh: mesh_index,
            primitive: primitive_index,
            index,
            at,
            vertices: vertex_count,
        });
    }
    let normals = match primitive.get(&Semantic::Normals) {
        Some(accessor) => validate::read(&format!("{place}.attributes.NORMAL"), accessor.index(), || {
            reader.read_normals().map(|it| it.map(Vec3::from_array).collect())
        })?,
        None => face_normals(&positions, &indices),
    };
    let uvs = match primitive.get(&Semantic::TexCoords(0)) {
        Some(accessor) => validate::read(&format!("{place}.attributes.TEXCOORD_0"), accessor.index(), || {
            reader.read_tex_coords(0).map(|t| t.into_f32().map(Vec2::from_array).collect())
        })?,
        None => vec![Vec2::ZERO; vertex_count],
    };
    let tangents = match primitive.get(&Semantic::Tangents) {
        Some(accessor) => validate::read(&format!("{place}.attributes.TANGENT"), accessor.index(), || {
            reader.read_tangents().map(|t| t.map(Vec4::from_array).collect())
        })?,
        None => Vec::new(),
    };
    let material = primitive.material().index().unwrap_or(default_material);
    Ok(Primitive { positions, normals, uvs, tangents, indices, material })
}

/// Area-weighted vertex normals from the triangles.
fn face_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    normals.into_iter().map(|n| n.normalize_or(Vec3::Z)).collect()
}

fn to_rgba8(index: usize, data: gltf::image::Data) -> Result<Image, GltfError> {
    use gltf::image::Format;
    let (w, h) = (data.width, data.height);
    let px = &data.pixels;
    let rgba8 = match data.format {
        Format::R8G8B8A8 => px.clone(),
        Format::R8G8B8 => px.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect(),
        Format::R8G8 => px.chunks_exact(2).flat_map(|c| [c[0], c[0], c[0], c[1]]).collect(),
        Format::R8 => px.iter().flat_map(|&c| [c, c, c, 255]).collect(),
        other => return Err(GltfError::ImageFormat { image: index, format: format!("{other:?}") }),
    };
    Ok(Image { width: w, height: h, rgba8 })
}
