//! The glTF loader on arbitrary bytes, as JSON (`.gltf`) or binary (`.glb`, when
//! the input starts with its magic): `raykit_scene::gltf::GltfScene::from_slice`,
//! which validates accessors, views, buffers and the node graph before the
//! `gltf` crate's readers see them, then reads meshes, materials, images and
//! instances; and every error's message. Buffers and images named by a relative
//! URI resolve in a folder that does not exist, so only embedded data (data URIs
//! and the GLB's binary chunk) is read. None of it may panic, hang or allocate
//! without bound.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use raykit_scene::gltf::GltfScene;

fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(b"glTF") { "scene.glb" } else { "scene.gltf" };
    let path = Path::new("/nonexistent/raykit-fuzz").join(name);
    match GltfScene::from_slice(data, &path) {
        Ok(scene) => {
            std::hint::black_box((scene.meshes.len(), scene.instances.len(), scene.materials.len()));
        }
        Err(e) => {
            std::hint::black_box(e.to_string());
        }
    }
});
