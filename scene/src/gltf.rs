//! glTF 2.0 scenes (through the `gltf` crate): meshes of indexed triangles with
//! normals, texture coordinates and tangents, metallic-roughness materials with
//! their textures and alpha modes, and the node hierarchy flattened into mesh
//! instances with world transforms. What a renderer makes of it (one GAS per
//! mesh with a geometry per primitive, one instance per [`MeshInstance`]) is up
//! to the renderer.
//!
//! Bad files are [`GltfError`]s naming the problem and the fix: a buffer whose
//! file is missing, a primitive that is not triangles, an index past the
//! vertices, a primitive without positions, an image format with no texture
//! format.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec2, Vec3, Vec4};

/// Why a glTF file could not be loaded.
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
    /// A buffer's file is missing.
    #[error("glTF {path}: buffer {buffer} refers to `{uri}`, which is not at {resolved}; put the file beside the .gltf or fix the buffer's uri")]
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
    /// A primitive is not a triangle list.
    #[error("glTF mesh {mesh} primitive {primitive} has mode {mode}; only triangles are ray traced: triangulate it in the exporter (strips and fans too)")]
    NotTriangles {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
        /// Its mode.
        mode: String,
    },
    /// A primitive has no positions.
    #[error("glTF mesh {mesh} primitive {primitive} has no POSITION attribute; export the mesh with positions")]
    MissingPositions {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
    },
    /// An index names a vertex past the primitive's vertices.
    #[error("glTF mesh {mesh} primitive {primitive}: index {index} at position {at} names vertex {index} of {vertices}; the index buffer does not belong to these vertices (re-export the mesh)")]
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
    #[error("glTF mesh {mesh} primitive {primitive} has {count} indices, not a multiple of 3; a triangle list needs 3 per triangle")]
    IndexCount {
        /// The mesh.
        mesh: usize,
        /// The primitive.
        primitive: usize,
        /// The count.
        count: usize,
    },
    /// An image's pixel format has no texture format.
    #[error("glTF image {image} has pixel format {format}; save it as 8-bit (grey, RGB or RGBA) or 32-bit float")]
    ImageFormat {
        /// The image.
        image: usize,
        /// Its format.
        format: String,
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
    pub fn load(path: &Path) -> Result<GltfScene, GltfError> {
        let parse = |source| GltfError::Parse { path: path.to_owned(), source };
        let document = gltf::Gltf::open(path).map_err(parse)?;
        let base = path.parent().unwrap_or(Path::new("."));
        for buffer in document.buffers() {
            if let gltf::buffer::Source::Uri(uri) = buffer.source() {
                if uri.starts_with("data:") {
                    continue;
                }
                let resolved = base.join(uri);
                if !resolved.is_file() {
                    return Err(GltfError::MissingBuffer {
                        path: path.to_owned(),
                        buffer: buffer.index(),
                        uri: uri.to_owned(),
                        resolved,
                    });
                }
            }
        }
        let (document, buffers, images) = gltf::import(path).map_err(parse)?;

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
            for (p, primitive) in mesh.primitives().enumerate() {
                let m = mesh.index();
                if primitive.mode() != gltf::mesh::Mode::Triangles {
                    return Err(GltfError::NotTriangles {
                        mesh: m,
                        primitive: p,
                        mode: format!("{:?}", primitive.mode()),
                    });
                }
                let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let positions: Vec<Vec3> = reader
                    .read_positions()
                    .ok_or(GltfError::MissingPositions { mesh: m, primitive: p })?
                    .map(Vec3::from_array)
                    .collect();
                let n = positions.len();
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..n as u32).collect(),
                };
                if !indices.len().is_multiple_of(3) {
                    return Err(GltfError::IndexCount { mesh: m, primitive: p, count: indices.len() });
                }
                if let Some((at, &index)) = indices.iter().enumerate().find(|(_, &i)| i as usize >= n) {
                    return Err(GltfError::IndexOutOfRange { mesh: m, primitive: p, index, at, vertices: n });
                }
                let normals = match reader.read_normals() {
                    Some(it) => it.map(Vec3::from_array).collect(),
                    None => face_normals(&positions, &indices),
                };
                let uvs = match reader.read_tex_coords(0) {
                    Some(t) => t.into_f32().map(Vec2::from_array).collect(),
                    None => vec![Vec2::ZERO; n],
                };
                let tangents = reader.read_tangents().map(|t| t.map(Vec4::from_array).collect()).unwrap_or_default();
                let material = primitive.material().index().unwrap_or(default_material);
                primitives.push(Primitive { positions, normals, uvs, tangents, indices, material });
            }
            meshes.push(Mesh { name: mesh.name().map(str::to_owned), primitives });
        }

        let mut instances = Vec::new();
        if let Some(scene) = document.default_scene().or_else(|| document.scenes().next()) {
            for node in scene.nodes() {
                collect_instances(&node, Mat4::IDENTITY, &mut instances);
            }
        }
        Ok(GltfScene { meshes, instances, materials, images })
    }
}

fn collect_instances(node: &gltf::Node, parent: Mat4, out: &mut Vec<MeshInstance>) {
    let transform = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
    if let Some(mesh) = node.mesh() {
        out.push(MeshInstance { mesh: mesh.index(), node: node.index(), transform });
    }
    for child in node.children() {
        collect_instances(&child, transform, out);
    }
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
