//! The loader against hostile files, written here as JSON with `data:` buffers:
//! each is the exact error variant, its message naming the glTF path; and a
//! valid scene loads as it should.

use std::path::PathBuf;

use glam::{Mat4, Vec2, Vec3};

use super::nodes::MAX_NODE_INSTANCES;
use super::validate::MAX_ZERO_FILLED_COUNT;
use super::*;

/// Standard base64 with padding, for `data:` uris.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The triangle's buffer: positions (bytes 0..36), normals (36..72), texture
/// coordinates (72..96), three `u16` indices (96..102), two bytes of padding.
fn triangle_bin() -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bin.extend(v.iter().flat_map(|c| c.to_le_bytes()));
    }
    for _ in 0..3 {
        bin.extend([0.0f32, 0.0, 1.0].iter().flat_map(|c| c.to_le_bytes()));
    }
    for uv in [[0.0f32, 0.0], [1.0, 0.0], [0.0, 1.0]] {
        bin.extend(uv.iter().flat_map(|c| c.to_le_bytes()));
    }
    bin.extend([0u16, 1, 2].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend([0, 0]);
    bin
}

const VIEWS: &str = r#"[
    {"buffer": 0, "byteOffset": 0, "byteLength": 36},
    {"buffer": 0, "byteOffset": 36, "byteLength": 36},
    {"buffer": 0, "byteOffset": 72, "byteLength": 24},
    {"buffer": 0, "byteOffset": 96, "byteLength": 6}
]"#;

const ACCESSORS: &str = r#"[
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
    {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
    {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}
]"#;

const PRIMITIVE: &str = r#"{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}"#;

const NODES: &str = r#"[{"mesh": 0}]"#;

/// A glTF document of one mesh of one primitive, with the triangle's buffer
/// unless `bin` replaces it.
struct Doc {
    bin: Vec<u8>,
    views: String,
    accessors: String,
    primitive: String,
    nodes: String,
    roots: String,
}

impl Doc {
    fn triangle() -> Doc {
        Doc {
            bin: triangle_bin(),
            views: VIEWS.to_owned(),
            accessors: ACCESSORS.to_owned(),
            primitive: PRIMITIVE.to_owned(),
            nodes: NODES.to_owned(),
            roots: "[0]".to_owned(),
        }
    }
    fn accessors(self, accessors: &str) -> Doc {
        Doc { accessors: accessors.to_owned(), ..self }
    }
    fn views(self, views: &str) -> Doc {
        Doc { views: views.to_owned(), ..self }
    }
    fn primitive(self, primitive: &str) -> Doc {
        Doc { primitive: primitive.to_owned(), ..self }
    }
    fn nodes(self, nodes: String, roots: &str) -> Doc {
        Doc { nodes, roots: roots.to_owned(), ..self }
    }
    fn json(&self) -> String {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": {roots}}}], "nodes": {nodes},
  "meshes": [{{"primitives": [{primitive}]}}],
  "buffers": [{{"byteLength": {length}, "uri": "data:application/octet-stream;base64,{data}"}}],
  "bufferViews": {views}, "accessors": {accessors}}}"#,
            roots = self.roots,
            nodes = self.nodes,
            primitive = self.primitive,
            length = self.bin.len(),
            data = base64(&self.bin),
            views = self.views,
            accessors = self.accessors,
        )
    }
    /// Writes the document into its own temporary directory and loads it.
    fn load(&self, name: &str) -> Result<GltfScene, GltfError> {
        let dir: PathBuf = std::env::temp_dir().join(format!("raykit_scene_gltf_{}_{name}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temporary directory");
        let path = dir.join("scene.gltf");
        std::fs::write(&path, self.json()).expect("write the test file");
        let loaded = GltfScene::load(&path);
        let _ = std::fs::remove_dir_all(&dir);
        loaded
    }
}

/// The load's error, which must name `path`.
fn error_naming(doc: &Doc, name: &str, path: &str) -> GltfError {
    match doc.load(name) {
        Ok(_) => panic!("{name}: the hostile file loaded"),
        Err(e) => {
            assert!(e.to_string().contains(path), "{name}: `{e}` does not name {path}");
            e
        }
    }
}

const POSITION: &str = "meshes[0].primitives[0].attributes.POSITION";

#[test]
fn a_valid_triangle_loads_exactly() {
    let scene = Doc::triangle().load("valid").expect("the valid triangle loads");
    let expected = GltfScene {
        meshes: vec![Mesh {
            name: None,
            primitives: vec![Primitive {
                positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
                normals: vec![Vec3::Z; 3],
                uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y],
                tangents: Vec::new(),
                indices: vec![0, 1, 2],
                material: 0,
            }],
        }],
        instances: vec![MeshInstance { mesh: 0, node: 0, transform: Mat4::IDENTITY }],
        materials: vec![Material::default()],
        images: Vec::new(),
    };
    assert_eq!(scene, expected);
}

/// The document as binary glTF: the JSON chunk, then the buffer as the BIN chunk.
fn glb(doc: &Doc) -> Vec<u8> {
    let data_uri = format!(r#", "uri": "data:application/octet-stream;base64,{}""#, base64(&doc.bin));
    let mut json = doc.json().replace(&data_uri, "").into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = doc.bin.clone();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    for word in [0x4654_6C67, 2, total as u32, json.len() as u32, 0x4E4F_534A] {
        out.extend(u32::to_le_bytes(word));
    }
    out.extend(json);
    for word in [bin.len() as u32, 0x004E_4942] {
        out.extend(u32::to_le_bytes(word));
    }
    out.extend(bin);
    out
}

#[test]
fn a_valid_glb_loads_as_its_gltf() {
    let doc = Doc::triangle();
    let dir = std::env::temp_dir().join(format!("raykit_scene_gltf_{}_glb", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let path = dir.join("scene.glb");
    std::fs::write(&path, glb(&doc)).expect("write the test file");
    let loaded = GltfScene::load(&path);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(loaded.expect("the .glb loads"), doc.load("glb_as_gltf").expect("the .gltf loads"));
}

#[test]
fn a_valid_hierarchy_and_a_sparse_accessor_load_as_written() {
    // POSITION: zeros without a view, vertices 1 and 2 replaced by the sparse values (bytes 12..36).
    let accessors = r#"[
        {"componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0],
         "sparse": {"count": 2, "indices": {"bufferView": 3, "byteOffset": 2, "componentType": 5123},
                    "values": {"bufferView": 0, "byteOffset": 12}}},
        {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}
    ]"#;
    let nodes = r#"[{"children": [1, 2], "translation": [1, 0, 0]}, {"mesh": 0, "scale": [2, 2, 2]},
        {"children": [3], "translation": [0, 5, 0]}, {"mesh": 0}]"#;
    let scene = Doc::triangle().accessors(accessors).nodes(nodes.to_owned(), "[0]").load("hierarchy").expect("loads");
    assert_eq!(scene.meshes[0].primitives[0].positions, [Vec3::ZERO, Vec3::X, Vec3::Y]);
    let placed: Vec<(usize, usize, Mat4)> = scene.instances.iter().map(|i| (i.mesh, i.node, i.transform)).collect();
    let root = Mat4::from_translation(Vec3::X);
    assert_eq!(
        placed,
        [(0, 1, root * Mat4::from_scale(Vec3::splat(2.0))), (0, 3, root * Mat4::from_translation(5.0 * Vec3::Y))]
    );
}

#[test]
fn a_node_listing_itself_is_a_cycle() {
    let doc = Doc::triangle().nodes(r#"[{"mesh": 0, "children": [0]}]"#.to_owned(), "[0]");
    let e = error_naming(&doc, "self_child", "nodes[0].children[0]");
    assert!(matches!(&e, GltfError::NodeCycle { child: 0, cycle, .. } if cycle == &[0, 0]), "{e}");
}

#[test]
fn a_node_listing_an_ancestor_is_a_cycle() {
    let nodes = r#"[{"children": [1]}, {"children": [2]}, {"mesh": 0, "children": [3, 0]}, {}]"#;
    let doc = Doc::triangle().nodes(nodes.to_owned(), "[0]");
    let e = error_naming(&doc, "ancestor_child", "nodes[2].children[1]");
    assert!(matches!(&e, GltfError::NodeCycle { child: 0, cycle, .. } if cycle == &[0, 1, 2, 0]), "{e}");
    assert!(e.to_string().contains("0 → 1 → 2 → 0"), "{e}");
}

#[test]
fn a_hierarchy_200000_nodes_deep_loads_without_recursion() {
    const DEPTH: usize = 200_000;
    let mut nodes: Vec<String> =
        (0..DEPTH - 1).map(|i| format!(r#"{{"children": [{}], "translation": [0, 0, 1]}}"#, i + 1)).collect();
    nodes.push(r#"{"mesh": 0, "translation": [0, 0, 1]}"#.to_owned());
    let doc = Doc::triangle().nodes(format!("[{}]", nodes.join(",")), "[0]");
    let scene = doc.load("deep").expect("a deep legal hierarchy loads");
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(scene.instances[0].node, DEPTH - 1);
    assert_eq!(scene.instances[0].transform, Mat4::from_translation(Vec3::new(0.0, 0.0, DEPTH as f32)));
}

#[test]
fn a_shared_subtree_is_instanced_once_per_path() {
    let nodes = r#"[{"children": [1, 1]}, {"children": [2], "translation": [1, 0, 0]}, {"mesh": 0}]"#;
    let scene = Doc::triangle().nodes(nodes.to_owned(), "[0, 1]").load("shared").expect("loads");
    let placed: Vec<usize> = scene.instances.iter().map(|i| i.node).collect();
    assert_eq!(placed, [2, 2, 2]);
    assert!(scene.instances.iter().all(|i| i.transform == Mat4::from_translation(Vec3::X)));
}

#[test]
fn forty_nodes_listing_the_next_twice_stop_at_the_instance_cap() {
    let mut nodes: Vec<String> = (0..39).map(|i| format!(r#"{{"children": [{0}, {0}]}}"#, i + 1)).collect();
    nodes.push(r#"{"mesh": 0}"#.to_owned());
    let doc = Doc::triangle().nodes(format!("[{}]", nodes.join(",")), "[0]");
    let e = error_naming(&doc, "dag", "].children[");
    assert!(matches!(e, GltfError::TooManyNodeInstances { limit: MAX_NODE_INSTANCES, .. }), "{e}");
}

#[test]
fn positions_with_count_zero_are_an_empty_accessor() {
    let doc = Doc::triangle()
        .accessors(&ACCESSORS.replacen(
            r#""count": 3, "type": "VEC3", "min""#,
            r#""count": 0, "type": "VEC3", "min""#,
            1,
        ))
        .primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "count_zero", POSITION);
    assert!(matches!(e, GltfError::EmptyAccessor { accessor: 0, .. }), "{e}");
}

#[test]
fn a_sparse_count_of_zero_is_a_sparse_count_error() {
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
        "sparse": {"count": 0, "indices": {"bufferView": 3, "componentType": 5123}, "values": {"bufferView": 0}}}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "sparse_zero", POSITION);
    assert!(matches!(e, GltfError::SparseCount { accessor: 0, sparse: 0, count: 3, .. }), "{e}");
}

#[test]
fn a_sparse_count_past_the_accessor_is_a_sparse_count_error() {
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 1, "type": "VEC3",
        "sparse": {"count": 2, "indices": {"bufferView": 3, "componentType": 5123}, "values": {"bufferView": 0}}}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "sparse_over", POSITION);
    assert!(matches!(e, GltfError::SparseCount { sparse: 2, count: 1, .. }), "{e}");
}

#[test]
fn sparse_values_past_their_view_are_out_of_bounds() {
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
        "sparse": {"count": 3, "indices": {"bufferView": 3, "componentType": 5123},
                   "values": {"bufferView": 0, "byteOffset": 12}}}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "sparse_values", POSITION);
    assert!(
        matches!(
            e,
            GltfError::AccessorOutOfBounds { part: ".sparse.values", view: 0, start: 12, end: 48, length: 36, .. }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("accessors[0].sparse.values"), "{e}");
}

#[test]
fn a_sparse_index_past_the_count_is_a_sparse_index_error() {
    // The sparse index is the u16 at byte 4 of the index view: 2, past a count of 2.
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3",
        "sparse": {"count": 1, "indices": {"bufferView": 3, "byteOffset": 4, "componentType": 5123}, "values": {"bufferView": 0}}}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "sparse_index_past", POSITION);
    assert!(matches!(e, GltfError::SparseIndex { at: 0, index: 2, previous: None, count: 2, .. }), "{e}");
    assert!(e.to_string().contains("accessors[0].sparse.indices[0]"), "{e}");
}

#[test]
fn sparse_indices_that_do_not_increase_are_a_sparse_index_error() {
    // The index view's bytes read as UNSIGNED_BYTE: 0, 0, 1, ...
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
        "sparse": {"count": 2, "indices": {"bufferView": 3, "componentType": 5121}, "values": {"bufferView": 0}}}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "sparse_index_repeated", POSITION);
    assert!(matches!(e, GltfError::SparseIndex { at: 1, index: 0, previous: Some(0), count: 3, .. }), "{e}");
}

#[test]
fn float_indices_are_an_accessor_type_error() {
    let accessors = ACCESSORS.replace(
        r#""componentType": 5123, "count": 3, "type": "SCALAR""#,
        r#""componentType": 5126, "count": 1, "type": "SCALAR""#,
    );
    let doc = Doc::triangle().accessors(&accessors);
    let e = error_naming(&doc, "float_indices", "meshes[0].primitives[0].indices");
    assert!(matches!(&e, GltfError::AccessorType { accessor: 3, found, .. } if found == "SCALAR of FLOAT"), "{e}");
}

#[test]
fn vec2_positions_are_an_accessor_type_error() {
    let accessors =
        r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC2"}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "vec2_positions", POSITION);
    assert!(matches!(&e, GltfError::AccessorType { found, .. } if found == "VEC2 of FLOAT"), "{e}");
    assert!(e.to_string().contains("VEC3 of FLOAT"), "{e}");
}

#[test]
fn unsigned_byte_positions_are_an_accessor_type_error() {
    let accessors =
        r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5121, "count": 3, "type": "VEC3"}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "u8_positions", POSITION);
    assert!(matches!(&e, GltfError::AccessorType { found, .. } if found == "VEC3 of UNSIGNED_BYTE"), "{e}");
}

#[test]
fn matrix_texture_coordinates_are_an_accessor_type_error() {
    let accessors = ACCESSORS.replace(r#""count": 3, "type": "VEC2""#, r#""count": 3, "type": "MAT2""#);
    let doc = Doc::triangle().accessors(&accessors);
    let e = error_naming(&doc, "mat2_uv", "meshes[0].primitives[0].attributes.TEXCOORD_0");
    assert!(matches!(e, GltfError::AccessorType { accessor: 2, .. }), "{e}");
}

#[test]
fn a_count_of_2_to_the_62_is_too_large() {
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 4611686018427387904, "type": "VEC3"}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "count_2_62", POSITION);
    assert!(matches!(e, GltfError::AccessorTooLarge { count: 4611686018427387904, .. }), "{e}");
}

#[test]
fn a_count_past_the_view_is_out_of_bounds() {
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "componentType": 5126, "count": 1000, "type": "VEC3"}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "count_past_view", POSITION);
    assert!(matches!(e, GltfError::AccessorOutOfBounds { part: "", view: 0, end: 12000, length: 36, .. }), "{e}");
}

#[test]
fn a_view_offset_near_2_to_the_64_is_out_of_bounds() {
    let views = VIEWS.replacen(
        r#""byteOffset": 0, "byteLength": 36"#,
        r#""byteOffset": 18446744073709551600, "byteLength": 36"#,
        1,
    );
    let doc = Doc::triangle().views(&views);
    let e = error_naming(&doc, "view_offset", "bufferViews[0]");
    assert!(matches!(e, GltfError::ViewOutOfBounds { buffer: 0, start: 18446744073709551600, length: 104, .. }), "{e}");
}

#[test]
fn an_accessor_offset_past_its_view_is_out_of_bounds_not_missing_positions() {
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "bufferView": 0, "byteOffset": 40, "componentType": 5126, "count": 3, "type": "VEC3"}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "offset_past_view", POSITION);
    assert!(matches!(e, GltfError::AccessorOutOfBounds { start: 40, length: 36, .. }), "{e}");
    assert!(!e.to_string().contains("no POSITION"), "{e}");
}

#[test]
fn a_stride_shorter_than_the_element_is_a_stride_error() {
    let views = VIEWS.replacen(r#""byteLength": 36}"#, r#""byteLength": 36, "byteStride": 4}"#, 1);
    let doc = Doc::triangle().views(&views);
    let e = error_naming(&doc, "short_stride", POSITION);
    assert!(matches!(e, GltfError::AccessorStride { stride: 4, element: 12, view: 0, .. }), "{e}");
}

#[test]
fn an_accessor_without_view_or_sparse_is_refused_by_the_parser() {
    // The parser's validation refuses it before the loader's own check (`AccessorWithoutData`) runs.
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "componentType": 5126, "count": 3, "type": "VEC3"}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "no_view", "accessors[0].bufferView");
    assert!(matches!(e, GltfError::Parse { .. }), "{e}");
}

#[test]
fn a_huge_zero_filled_sparse_accessor_is_too_large() {
    let accessors = r#"[{"min": [0, 0, 0], "max": [1, 1, 0], "componentType": 5126, "count": 1099511627776, "type": "VEC3",
        "sparse": {"count": 1, "indices": {"bufferView": 3, "componentType": 5123}, "values": {"bufferView": 0}}}]"#;
    let doc = Doc::triangle().accessors(accessors).primitive(r#"{"attributes": {"POSITION": 0}}"#);
    let e = error_naming(&doc, "zero_filled", POSITION);
    assert!(matches!(e, GltfError::AccessorTooLarge { limit: MAX_ZERO_FILLED_COUNT, .. }), "{e}");
}

#[test]
fn normals_fewer_than_positions_are_an_attribute_count_error() {
    let accessors = ACCESSORS.replacen(
        r#""bufferView": 1, "componentType": 5126, "count": 3"#,
        r#""bufferView": 1, "componentType": 5126, "count": 2"#,
        1,
    );
    let doc = Doc::triangle().accessors(&accessors);
    let e = error_naming(&doc, "few_normals", "meshes[0].primitives[0].attributes.NORMAL");
    assert!(matches!(e, GltfError::AttributeCount { accessor: 1, count: 2, positions: 3, .. }), "{e}");
}

#[test]
fn texture_coordinates_fewer_than_positions_are_an_attribute_count_error() {
    let accessors = ACCESSORS.replacen(
        r#""bufferView": 2, "componentType": 5126, "count": 3"#,
        r#""bufferView": 2, "componentType": 5126, "count": 1"#,
        1,
    );
    let doc = Doc::triangle().accessors(&accessors);
    let e = error_naming(&doc, "few_uvs", "meshes[0].primitives[0].attributes.TEXCOORD_0");
    assert!(matches!(e, GltfError::AttributeCount { accessor: 2, count: 1, positions: 3, .. }), "{e}");
}

#[test]
fn tangents_of_the_wrong_count_are_an_attribute_count_error() {
    // Two VEC4 tangents (32 bytes) from the normals' view, for three positions.
    let accessors = format!(
        "{}, {}]",
        ACCESSORS.trim_end().trim_end_matches(']'),
        r#"{"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC4"}"#
    );
    let doc = Doc::triangle()
        .accessors(&accessors)
        .primitive(r#"{"attributes": {"POSITION": 0, "NORMAL": 1, "TANGENT": 4}, "indices": 3}"#);
    let e = error_naming(&doc, "few_tangents", "meshes[0].primitives[0].attributes.TANGENT");
    assert!(matches!(e, GltfError::AttributeCount { accessor: 4, count: 2, positions: 3, .. }), "{e}");
}

#[test]
fn the_existing_messages_name_their_paths() {
    let lines = Doc::triangle().primitive(r#"{"attributes": {"POSITION": 0}, "mode": 1}"#);
    let e = error_naming(&lines, "lines", "meshes[0].primitives[0].mode");
    assert!(matches!(e, GltfError::NotTriangles { mesh: 0, primitive: 0, .. }), "{e}");
    let no_positions = Doc::triangle().primitive(r#"{"attributes": {"NORMAL": 1}}"#);
    let e = error_naming(&no_positions, "no_positions", "meshes[0].primitives[0].attributes");
    // The parser's validation already refuses a primitive without POSITION.
    assert!(matches!(e, GltfError::Parse { .. }), "{e}");
    let two_indices = Doc::triangle()
        .accessors(&ACCESSORS.replace(r#""count": 3, "type": "SCALAR""#, r#""count": 2, "type": "SCALAR""#));
    let e = error_naming(&two_indices, "two_indices", "meshes[0].primitives[0].indices");
    assert!(matches!(e, GltfError::IndexCount { count: 2, .. }), "{e}");
}

/// `bytes` loaded from memory as `name`; must be refused with a parse error.
fn parse_error_of(bytes: &[u8], name: &str) -> GltfError {
    let path = std::env::temp_dir().join("raykit-scene-no-such-folder").join(name);
    match GltfScene::from_slice(bytes, &path) {
        Ok(_) => panic!("{name}: the hostile bytes loaded"),
        Err(e) => {
            assert!(matches!(e, GltfError::Parse { .. }), "{name}: {e:?}");
            assert!(e.to_string().contains(name), "{name}: `{e}` does not name the file");
            e
        }
    }
}

#[test]
fn a_scene_in_memory_loads_as_its_file() {
    let doc = Doc::triangle();
    let path = std::env::temp_dir().join("raykit-scene-no-such-folder").join("scene.glb");
    let from_memory = GltfScene::from_slice(&glb(&doc), &path).expect("the .glb loads from memory");
    assert_eq!(from_memory, doc.load("memory_as_file").expect("the .gltf loads"));
}

#[test]
fn empty_and_truncated_files_are_parse_errors() {
    parse_error_of(b"", "empty.gltf");
    parse_error_of(b"glTF", "magic_only.glb");
    let whole = glb(&Doc::triangle());
    for cut in [12, 20, whole.len() / 2, whole.len() - 1] {
        parse_error_of(&whole[..cut], "truncated.glb");
    }
}

#[test]
fn glb_headers_that_lie_are_parse_errors() {
    let whole = glb(&Doc::triangle());
    let with_word = |at: usize, word: u32| {
        let mut bytes = whole.clone();
        bytes[at..at + 4].copy_from_slice(&word.to_le_bytes());
        bytes
    };
    // Version 1, a total length of 4 GiB, a JSON chunk past the end, a first chunk that is not JSON.
    for (at, word) in [(4, 1), (8, u32::MAX), (12, u32::MAX - 3), (16, 0x004E_4942)] {
        parse_error_of(&with_word(at, word), "lying_header.glb");
    }
}

#[test]
fn json_nested_past_the_parser_limit_is_a_parse_error_not_a_stack_overflow() {
    let depth = 200_000;
    let json = format!(r#"{{"asset": {{"version": "2.0"}}, "extras": {}{}}}"#, "[".repeat(depth), "]".repeat(depth));
    parse_error_of(json.as_bytes(), "nested.gltf");
}

#[test]
fn json_that_is_not_utf8_or_not_gltf_is_a_parse_error() {
    parse_error_of(b"{\"asset\": {\"version\": \"2.0\xff\"}}", "not_utf8.gltf");
    parse_error_of(b"[1, 2, 3]", "array.gltf");
    parse_error_of(br#"{"asset": {"version": "2.0"}, "meshes": 7}"#, "meshes_not_an_array.gltf");
}

#[test]
fn a_data_uri_that_is_not_base64_or_is_short_is_an_error() {
    let json = Doc::triangle().json();
    let data = base64(&triangle_bin());
    let bad = json.replace(&data, "!!!not base64!!!");
    assert!(GltfScene::from_slice(bad.as_bytes(), std::path::Path::new("bad_base64.gltf")).is_err());
    // Half the bytes the buffer declares.
    let short = json.replace(&data, &base64(&triangle_bin()[..48]));
    assert!(GltfScene::from_slice(short.as_bytes(), std::path::Path::new("short.gltf")).is_err());
}

#[test]
fn a_position_accessor_past_the_accessors_is_a_dangling_index_not_a_panic() {
    // Found by fuzzing: the `gltf` crate's validation indexed it and panicked.
    let doc =
        Doc::triangle().primitive(r#"{"attributes": {"POSITION": 4, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}"#);
    let err = error_naming(&doc, "dangling_position", POSITION);
    assert!(matches!(err, GltfError::DanglingIndex { index: 4, count: 4, target: "accessors", .. }), "{err:?}");
    let path = std::env::temp_dir().join("raykit-scene-no-such-folder").join("scene.glb");
    let from_glb = GltfScene::from_slice(&glb(&doc), &path);
    assert!(matches!(from_glb, Err(GltfError::DanglingIndex { index: 4, .. })), "{from_glb:?}");
    // A NORMAL past them is the `gltf` crate's own validation error.
    let doc = Doc::triangle().primitive(r#"{"attributes": {"POSITION": 0, "NORMAL": 9}, "indices": 3}"#);
    assert!(matches!(doc.load("dangling_normal"), Err(GltfError::Parse { .. })));
}

/// A folder `root` holding `scene/` (where the glTF files go, with
/// `scene/inside.bin` and an empty `scene/sub/`), `outside.bin` next to it and
/// `scene/link.bin`, a symbolic link to `../outside.bin`; removed on drop.
struct Folders {
    root: PathBuf,
}

impl Folders {
    fn new(name: &str) -> Folders {
        let root = std::env::temp_dir().join(format!("raykit_scene_folders_{}_{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("scene/sub")).expect("temporary directory");
        std::fs::write(root.join("outside.bin"), triangle_bin()).expect("write outside.bin");
        std::fs::write(root.join("scene/inside.bin"), triangle_bin()).expect("write inside.bin");
        #[cfg(unix)]
        std::os::unix::fs::symlink("../outside.bin", root.join("scene/link.bin")).expect("symbolic link");
        Folders { root }
    }

    /// The triangle with its buffer at `uri`, written as `scene/scene.gltf`.
    fn scene_with_buffer(&self, uri: &str) -> PathBuf {
        let data = format!("data:application/octet-stream;base64,{}", base64(&triangle_bin()));
        let path = self.root.join("scene/scene.gltf");
        std::fs::write(&path, Doc::triangle().json().replace(&data, uri)).expect("write the test file");
        path
    }
}

impl Drop for Folders {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

#[test]
fn buffer_uris_reach_only_the_scene_folder() {
    let folders = Folders::new("buffers");
    let outside = folders.root.join("outside.bin");
    let want = Doc::triangle().load("folder_reference").expect("the triangle loads");
    let mut refused = vec![
        outside.to_str().expect("a UTF-8 temporary directory").to_owned(),
        format!("file://{}", outside.display()),
        "../outside.bin".to_owned(),
        "sub/../../outside.bin".to_owned(),
        "sub/%2E%2E/../outside.bin".to_owned(),
    ];
    if cfg!(unix) {
        refused.push("link.bin".to_owned());
    }
    for uri in &refused {
        let path = folders.scene_with_buffer(uri);
        match GltfScene::load(&path) {
            Err(e @ GltfError::OutsideFolder { .. }) => {
                let message = e.to_string();
                let GltfError::OutsideFolder { reference, resolved, folder, .. } = &e else { unreachable!() };
                assert_eq!(reference, "buffers[0].uri");
                assert_eq!(resolved, &outside.canonicalize().unwrap());
                assert_eq!(folder, &folders.root.join("scene").canonicalize().unwrap());
                for says in [uri.as_str(), "buffers[0].uri", "outside the scene's folder", "allow_outside_folder: true"]
                {
                    assert!(message.contains(says), "{uri}: `{message}` does not say {says:?}");
                }
            }
            other => panic!("{uri}: {other:?}"),
        }
        // The opt-out reads it.
        let trusted = GltfScene::load_with(&path, &LoadOptions { allow_outside_folder: true });
        assert_eq!(trusted.expect("the opt-out loads it"), want, "{uri}");
    }
    for uri in ["inside.bin", "./inside.bin", "sub/../inside.bin", "%69nside.bin"] {
        let loaded = GltfScene::load(&folders.scene_with_buffer(uri));
        assert_eq!(loaded.expect(uri), want, "{uri}");
    }
    // A data: uri reads no file at all.
    let data = format!("data:application/octet-stream;base64,{}", base64(&triangle_bin()));
    assert_eq!(GltfScene::load(&folders.scene_with_buffer(&data)).expect("data: uri"), want);
}

#[test]
fn image_uris_reach_only_the_scene_folder() {
    let folders = Folders::new("images");
    image::RgbaImage::from_pixel(1, 1, image::Rgba([10, 20, 30, 255])).save(folders.root.join("outside.png")).unwrap();
    std::fs::copy(folders.root.join("outside.png"), folders.root.join("scene/inside.png")).unwrap();
    let with_image = |uri: &str| {
        let path = folders.root.join("scene/image.gltf");
        let json = Doc::triangle().json();
        let json = json.replacen(
            r#""asset": {"version": "2.0"},"#,
            &format!(r#""asset": {{"version": "2.0"}}, "images": [{{"uri": "{uri}"}}],"#),
            1,
        );
        std::fs::write(&path, json).unwrap();
        path
    };
    let inside = GltfScene::load(&with_image("inside.png")).expect("an image beside the file loads");
    assert_eq!(inside.images, vec![Image { width: 1, height: 1, rgba8: vec![10, 20, 30, 255] }]);
    let path = with_image("../outside.png");
    match GltfScene::load(&path) {
        Err(GltfError::OutsideFolder { reference, .. }) => assert_eq!(reference, "images[0].uri"),
        other => panic!("{other:?}"),
    }
    let trusted = GltfScene::load_with(&path, &LoadOptions { allow_outside_folder: true }).expect("the opt-out");
    assert_eq!(trusted.images, inside.images);
    match GltfScene::load(&with_image("missing.png")) {
        Err(e @ GltfError::MissingImage { image: 0, .. }) => assert!(e.to_string().contains("missing.png"), "{e}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn uris_whose_escapes_are_not_utf8_are_errors_not_panics() {
    let folders = Folders::new("escapes");
    let path = folders.scene_with_buffer("inside%FF.bin");
    match GltfScene::load(&path) {
        Err(e @ GltfError::UriEncoding { .. }) => assert!(e.to_string().contains("inside%FF.bin"), "{e}"),
        other => panic!("{other:?}"),
    }
    // An image's uri too (the `gltf` crate's decoder panicked on it).
    let json = Doc::triangle().json().replacen(
        r#""asset": {"version": "2.0"},"#,
        r#""asset": {"version": "2.0"}, "images": [{"uri": "x%C3%28.png"}],"#,
        1,
    );
    std::fs::write(&path, json).unwrap();
    match GltfScene::load(&path) {
        Err(GltfError::UriEncoding { reference, .. }) => assert_eq!(reference, "images[0].uri"),
        other => panic!("{other:?}"),
    }
    assert_eq!(percent_decode("a%20b%2"), Some("a b%2".to_owned()));
    assert_eq!(percent_decode("%+F%zz"), Some("%+F%zz".to_owned()));
    assert_eq!(percent_decode("%C3%A9"), Some("é".to_owned()));
}
