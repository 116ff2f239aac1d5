//! A generated glTF scene for the material benchmarks: a grid of quads, each
//! its own mesh with its own material (a base colour), facing +z.

use std::path::{Path, PathBuf};

/// Writes `grid.gltf` and `grid.bin` into `dir`: `count` quads in a square grid
/// covering `[-1, 1]²` at z = 0, quad `i` with material `i`. Returns the `.gltf` path.
pub fn write_grid(dir: &Path, count: u32) -> anyhow::Result<PathBuf> {
    anyhow::ensure!(count > 0, "a grid needs at least one quad");
    std::fs::create_dir_all(dir)?;
    let positions: [[f32; 3]; 4] = [[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]];
    let normals = [[0.0f32, 0.0, 1.0]; 4];
    let uvs: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let indices: [u32; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin = Vec::new();
    bin.extend_from_slice(bytemuck::cast_slice(&positions));
    bin.extend_from_slice(bytemuck::cast_slice(&normals));
    bin.extend_from_slice(bytemuck::cast_slice(&uvs));
    bin.extend_from_slice(bytemuck::cast_slice(&indices));
    let side = (count as f32).sqrt().ceil() as u32;
    let cell = 2.0 / side as f32;
    let mut nodes = Vec::new();
    let mut meshes = Vec::new();
    let mut materials = Vec::new();
    for i in 0..count {
        let (x, y) = (i % side, i / side);
        let t = [-1.0 + cell * (x as f32 + 0.5), 1.0 - cell * (y as f32 + 0.5), 0.0];
        nodes.push(format!(r#"{{"mesh":{i},"translation":[{},{},{}],"scale":[{cell},{cell},1]}}"#, t[0], t[1], t[2]));
        meshes.push(format!(
            r#"{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2}},"indices":3,"material":{i}}}]}}"#
        ));
        let c = i as f32 / count as f32;
        materials.push(format!(r#"{{"pbrMetallicRoughness":{{"baseColorFactor":[{c},{},0.5,1.0]}}}}"#, 1.0 - c));
    }
    let scene_nodes: Vec<String> = (0..count).map(|i| i.to_string()).collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{}],"materials":[{}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-0.5,-0.5,0],"max":[0.5,0.5,0]}},
{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"}},{{"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"}},
{{"bufferView":3,"componentType":5125,"count":6,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":48}},
{{"buffer":0,"byteOffset":96,"byteLength":32}},{{"buffer":0,"byteOffset":128,"byteLength":24}}],
"buffers":[{{"uri":"grid.bin","byteLength":{}}}]}}"#,
        scene_nodes.join(","),
        nodes.join(","),
        meshes.join(","),
        materials.join(","),
        bin.len()
    );
    std::fs::write(dir.join("grid.bin"), &bin)?;
    let path = dir.join("grid.gltf");
    std::fs::write(&path, json)?;
    Ok(path)
}
