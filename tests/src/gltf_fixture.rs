//! A generator of small glTF 2.0 files for the glTF tests: two meshes (a board
//! and a plant of two primitives), three materials with PNG base-colour
//! textures (the third alpha-masked, with holes), a node hierarchy (a rotated,
//! scaled root over the board and a branch whose child, given as a matrix, holds
//! the plant with its masked leaf), and a backdrop. [`Broken`] variants write
//! the same file with one defect each.

use std::path::{Path, PathBuf};

use raykit::glam::{Mat4, Quat, Vec2, Vec3};

/// A defect to write into the file.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Broken {
    /// A correct file.
    Nothing,
    /// The buffer's `.bin` is not written.
    MissingBuffer,
    /// The board's primitive is drawn as lines.
    Lines,
    /// An index of the leaf names a vertex past its four.
    IndexOutOfRange,
}

/// The unit quad's positions (z = 0), normals, texture coordinates.
pub const QUAD: [Vec3; 4] =
    [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)];
/// The quad's texture coordinates (v = 0 at the top).
pub const QUAD_UV: [Vec2; 4] = [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];
/// The leaf's positions (in front of the plant's quad).
pub const LEAF: [Vec3; 4] =
    [Vec3::new(-0.8, -0.8, 0.3), Vec3::new(0.8, -0.8, 0.3), Vec3::new(0.8, 0.8, 0.3), Vec3::new(-0.8, 0.8, 0.3)];
/// The leaf's texture coordinates: the texture twice across.
pub const LEAF_UV: [Vec2; 4] = [Vec2::new(0.0, 2.0), Vec2::new(2.0, 2.0), Vec2::new(2.0, 0.0), Vec2::new(0.0, 0.0)];

/// The world transforms the hierarchy gives the three mesh nodes, in the order
/// of a depth-first walk: board, plant, backdrop.
pub fn expected_transforms() -> [Mat4; 3] {
    let root = Mat4::from_scale_rotation_translation(Vec3::splat(0.8), Quat::from_rotation_z(0.35), Vec3::ZERO);
    let board = Mat4::from_translation(Vec3::new(-0.7, 0.0, -0.5));
    let branch = Mat4::from_translation(Vec3::new(0.55, 0.1, 0.0));
    let leaf = leaf_matrix();
    let backdrop =
        Mat4::from_scale_rotation_translation(Vec3::new(3.0, 3.0, 1.0), Quat::IDENTITY, Vec3::new(0.0, 0.0, -2.0));
    [root * board, root * branch * leaf, backdrop]
}

fn leaf_matrix() -> Mat4 {
    Mat4::from_scale_rotation_translation(Vec3::splat(0.6), Quat::from_rotation_y(0.3), Vec3::new(0.0, 0.0, 0.5))
}

/// The texture images: a 4×4 red/white checker, an 8×8 gradient, an 8×8 green leaf whose alpha is 0
/// on a pattern of holes.
pub fn images() -> [image::RgbaImage; 3] {
    let checker = image::RgbaImage::from_fn(4, 4, |x, y| {
        if (x + y) % 2 == 0 {
            image::Rgba([230, 40, 30, 255])
        } else {
            image::Rgba([240, 240, 240, 255])
        }
    });
    let gradient = image::RgbaImage::from_fn(8, 8, |x, y| image::Rgba([(x * 32) as u8, (y * 32) as u8, 128, 255]));
    let leaf = image::RgbaImage::from_fn(8, 8, |x, y| {
        let hole = (x % 4 == 1 || x % 4 == 2) && (y % 4 == 1);
        image::Rgba([40, 180, 60, if hole { 0 } else { 255 }])
    });
    [checker, gradient, leaf]
}

/// Writes `scene.gltf`, `scene.bin` and three PNGs into `dir`; returns the `.gltf` path.
pub fn write(dir: &Path, broken: Broken) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: &[u8], target: u32| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{},"target":{target}}}"#,
            bin.len(),
            bytes.len()
        ));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let normals = [Vec3::Z; 4];
    let q_pos = push(bytemuck::cast_slice(&QUAD), 34962);
    let q_nrm = push(bytemuck::cast_slice(&normals), 34962);
    let q_uv = push(bytemuck::cast_slice(&QUAD_UV), 34962);
    let q_idx16 = push(bytemuck::cast_slice(&[0u16, 1, 2, 0, 2, 3]), 34963);
    let q_idx32 = push(bytemuck::cast_slice(&[0u32, 1, 2, 0, 2, 3]), 34963);
    let l_pos = push(bytemuck::cast_slice(&LEAF), 34962);
    let l_uv = push(bytemuck::cast_slice(&LEAF_UV), 34962);
    let leaf_last = if broken == Broken::IndexOutOfRange { 9u32 } else { 3 };
    let l_idx = push(bytemuck::cast_slice(&[0u32, 1, 2, 0, 2, leaf_last]), 34963);
    let vec3 = |view: usize, min: Vec3, max: Vec3| {
        format!(
            r#"{{"bufferView":{view},"componentType":5126,"count":4,"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
            min.x, min.y, min.z, max.x, max.y, max.z
        )
    };
    let accessors = [
        vec3(q_pos, Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)),
        format!(r#"{{"bufferView":{q_nrm},"componentType":5126,"count":4,"type":"VEC3"}}"#),
        format!(r#"{{"bufferView":{q_uv},"componentType":5126,"count":4,"type":"VEC2"}}"#),
        format!(r#"{{"bufferView":{q_idx16},"componentType":5123,"count":6,"type":"SCALAR"}}"#),
        format!(r#"{{"bufferView":{q_idx32},"componentType":5125,"count":6,"type":"SCALAR"}}"#),
        vec3(l_pos, Vec3::new(-0.8, -0.8, 0.3), Vec3::new(0.8, 0.8, 0.3)),
        format!(r#"{{"bufferView":{l_uv},"componentType":5126,"count":4,"type":"VEC2"}}"#),
        format!(r#"{{"bufferView":{l_idx},"componentType":5125,"count":6,"type":"SCALAR"}}"#),
    ];
    let board_mode = if broken == Broken::Lines { r#","mode":1"# } else { "" };
    let leaf = leaf_matrix().to_cols_array().map(|v| v.to_string()).join(",");
    let root_rotation = Quat::from_rotation_z(0.35);
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0", "generator": "raykit tests"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 4]}}],
  "nodes": [
    {{"name": "root", "scale": [0.8, 0.8, 0.8], "rotation": [{rx}, {ry}, {rz}, {rw}], "children": [1, 2]}},
    {{"name": "board", "mesh": 0, "translation": [-0.7, 0.0, -0.5]}},
    {{"name": "branch", "translation": [0.55, 0.1, 0.0], "children": [3]}},
    {{"name": "leaf", "mesh": 1, "matrix": [{leaf}]}},
    {{"name": "backdrop", "mesh": 0, "translation": [0.0, 0.0, -2.0], "scale": [3.0, 3.0, 1.0]}}
  ],
  "meshes": [
    {{"name": "board", "primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0{board_mode}}}]}},
    {{"name": "plant", "primitives": [
      {{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 4, "material": 1}},
      {{"attributes": {{"POSITION": 5, "NORMAL": 1, "TEXCOORD_0": 6}}, "indices": 7, "material": 2}}
    ]}}
  ],
  "materials": [
    {{"name": "checker", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}, "metallicFactor": 0.0, "roughnessFactor": 0.5}}}},
    {{"name": "gradient", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 1}}, "baseColorFactor": [1.0, 0.8, 0.6, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.2}}}},
    {{"name": "leaf", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 2}}, "metallicFactor": 0.0}}, "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": true}}
  ],
  "textures": [{{"source": 0}}, {{"source": 1}}, {{"source": 2}}],
  "images": [{{"uri": "checker.png"}}, {{"uri": "gradient.png"}}, {{"uri": "leaf.png"}}],
  "accessors": [{accessors}],
  "bufferViews": [{views}],
  "buffers": [{{"uri": "scene.bin", "byteLength": {len}}}]
}}
"#,
        rx = root_rotation.x,
        ry = root_rotation.y,
        rz = root_rotation.z,
        rw = root_rotation.w,
        accessors = accessors.join(","),
        views = views.join(","),
        len = bin.len(),
    );
    if broken != Broken::MissingBuffer {
        std::fs::write(dir.join("scene.bin"), &bin)?;
    }
    for (name, img) in ["checker.png", "gradient.png", "leaf.png"].iter().zip(images()) {
        img.save(dir.join(name))?;
    }
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json)?;
    Ok(path)
}

/// One quad of [`write_quads`]: its corners (counter-clockwise seen from `normal`),
/// texture coordinates [`QUAD_UV`], a tangent per vertex when given, a material index.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Quad {
    /// The corners, in [`QUAD`]'s order.
    pub corners: [Vec3; 4],
    /// The normal of every vertex.
    pub normal: Vec3,
    /// The tangent (xyz, w the bitangent sign) of every vertex, if the file has tangents.
    pub tangent: Option<raykit::glam::Vec4>,
    /// The material's index in `materials`.
    pub material: usize,
}

/// Writes `scene.gltf` and `scene.bin` into `dir`: one mesh and one node per quad, the
/// `materials`, `textures` and `images` given as glTF JSON arrays (images' files and
/// their pixels in `files`); returns the `.gltf` path.
pub fn write_quads(
    dir: &Path,
    quads: &[Quad],
    materials: &str,
    textures: &str,
    images: &str,
    files: &[(&str, image::RgbaImage)],
) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut nodes) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut push = |bytes: &[u8], target: u32, accessor: String| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{},"target":{target}}}"#,
            bin.len(),
            bytes.len()
        ));
        bin.extend_from_slice(bytes);
        accessors.push(accessor.replace("VIEW", &(views.len() - 1).to_string()));
        accessors.len() - 1
    };
    for (i, q) in quads.iter().enumerate() {
        let (lo, hi) = q.corners.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &c| (lo.min(c), hi.max(c)));
        let pos = push(
            bytemuck::cast_slice(&q.corners),
            34962,
            format!(
                r#"{{"bufferView":VIEW,"componentType":5126,"count":4,"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
                lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
            ),
        );
        let vec = |t: &str| format!(r#"{{"bufferView":VIEW,"componentType":5126,"count":4,"type":"{t}"}}"#);
        let nrm = push(bytemuck::cast_slice(&[q.normal; 4]), 34962, vec("VEC3"));
        let uv = push(bytemuck::cast_slice(&QUAD_UV), 34962, vec("VEC2"));
        let idx = push(
            bytemuck::cast_slice(&[0u32, 1, 2, 0, 2, 3]),
            34963,
            r#"{"bufferView":VIEW,"componentType":5125,"count":6,"type":"SCALAR"}"#.to_owned(),
        );
        let tangent = match q.tangent {
            Some(t) => format!(r#", "TANGENT": {}"#, push(bytemuck::cast_slice(&[t; 4]), 34962, vec("VEC4"))),
            None => String::new(),
        };
        meshes.push(format!(
            r#"{{"primitives": [{{"attributes": {{"POSITION": {pos}, "NORMAL": {nrm}, "TEXCOORD_0": {uv}{tangent}}}, "indices": {idx}, "material": {}}}]}}"#,
            q.material
        ));
        nodes.push(format!(r#"{{"mesh": {i}}}"#));
    }
    let roots: Vec<String> = (0..quads.len()).map(|i| i.to_string()).collect();
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0", "generator": "raykit tests"}},
  "extensionsUsed": ["KHR_materials_emissive_strength"],
  "scene": 0,
  "scenes": [{{"nodes": [{roots}]}}],
  "nodes": [{nodes}],
  "meshes": [{meshes}],
  "materials": {materials},{textures}
  "accessors": [{accessors}],
  "bufferViews": [{views}],
  "buffers": [{{"uri": "scene.bin", "byteLength": {len}}}]
}}
"#,
        roots = roots.join(","),
        textures = if files.is_empty() {
            String::new()
        } else {
            format!("\n  \"textures\": {textures},\n  \"images\": {images},")
        },
        nodes = nodes.join(","),
        meshes = meshes.join(","),
        accessors = accessors.join(","),
        views = views.join(","),
        len = bin.len(),
    );
    std::fs::write(dir.join("scene.bin"), &bin)?;
    for (name, img) in files {
        img.save(dir.join(name))?;
    }
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json)?;
    Ok(path)
}

/// A small emissive quad (0.5 × 0.5, 1 above the floor, facing down; emissive factor
/// `(1, 0.9, 0.8)` at `KHR_materials_emissive_strength` 20, black base colour) over a
/// diffuse 4 × 4 floor (base colour 0.8, metallic 0, roughness 1) at y = 0.
pub fn write_emissive_quad(dir: &Path) -> anyhow::Result<PathBuf> {
    let floor = Quad {
        corners: [
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, -2.0),
            Vec3::new(-2.0, 0.0, -2.0),
        ],
        normal: Vec3::Y,
        tangent: None,
        material: 0,
    };
    let h = 0.25;
    let light = Quad {
        corners: [Vec3::new(-h, 1.0, -h), Vec3::new(h, 1.0, -h), Vec3::new(h, 1.0, h), Vec3::new(-h, 1.0, h)],
        normal: -Vec3::Y,
        tangent: None,
        material: 1,
    };
    let materials = r#"[
    {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}},
    {"name": "light", "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0}, "emissiveFactor": [1.0, 0.9, 0.8], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 20.0}}}
  ]"#;
    write_quads(dir, &[floor, light], materials, "[]", "[]", &[])
}
