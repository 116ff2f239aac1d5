//! The node graph flattened into mesh instances, walked with an explicit stack.
//!
//! A hierarchy of any depth takes heap, not call stack. A node that lists
//! itself or an ancestor as a child is a [`GltfError::NodeCycle`] naming the
//! nodes. A node listed under several parents (a shared subtree; glTF asks for
//! a forest, but files have them) is instanced once per path from the root,
//! and the walk stops at [`MAX_NODE_INSTANCES`] node instances, so that a few
//! nodes listing each other twice cannot make it walk 2ⁿ paths.

use glam::Mat4;

use super::{GltfError, MeshInstance};

/// The most node instances (nodes along each path from the scene's roots,
/// with or without a mesh) a scene may reach: past it the load is a
/// [`GltfError::TooManyNodeInstances`].
pub const MAX_NODE_INSTANCES: usize = 1 << 20;

/// A node's part of the walk.
struct Node {
    /// Its local transform.
    local: Mat4,
    /// Its mesh.
    mesh: Option<usize>,
    /// Its children.
    children: Vec<usize>,
}

/// A node on the walk's current path.
struct Frame {
    /// The node.
    node: usize,
    /// Its world transform.
    transform: Mat4,
    /// The next of its children to visit.
    next_child: usize,
}

/// `a → b → c`, for [`GltfError::NodeCycle`]'s message.
pub(crate) fn arrows(nodes: &[usize]) -> String {
    nodes.iter().map(usize::to_string).collect::<Vec<_>>().join(" → ")
}

/// Every node of `scene` with a mesh, once per path from a root, in depth-first
/// order (a node before its children, children in the file's order), with its
/// world transform.
pub fn instances(document: &gltf::Document, scene: &gltf::Scene) -> Result<Vec<MeshInstance>, GltfError> {
    let nodes: Vec<Node> = document
        .nodes()
        .map(|n| Node {
            local: Mat4::from_cols_array_2d(&n.transform().matrix()),
            mesh: n.mesh().map(|m| m.index()),
            children: n.children().map(|c| c.index()).collect(),
        })
        .collect();
    let mut on_path = vec![false; nodes.len()];
    let mut stack: Vec<Frame> = Vec::new();
    let mut reached = 0usize;
    let mut out = Vec::new();
    // Enters `node` under `parent` (the path names the entry): counts it, records its instance, pushes its frame.
    let mut enter = |node: usize, parent: Mat4, path: &dyn Fn() -> String, stack: &mut Vec<Frame>| {
        reached += 1;
        if reached > MAX_NODE_INSTANCES {
            return Err(GltfError::TooManyNodeInstances { path: path(), limit: MAX_NODE_INSTANCES });
        }
        let transform = parent * nodes[node].local;
        if let Some(mesh) = nodes[node].mesh {
            out.push(MeshInstance { mesh, node, transform });
        }
        stack.push(Frame { node, transform, next_child: 0 });
        Ok(())
    };
    for (root_at, root) in scene.nodes().enumerate() {
        let scene_index = scene.index();
        enter(root.index(), Mat4::IDENTITY, &|| format!("scenes[{scene_index}].nodes[{root_at}]"), &mut stack)?;
        on_path[root.index()] = true;
        while let Some(top) = stack.last_mut() {
            let parent = top.node;
            let Some(&child) = nodes[parent].children.get(top.next_child) else {
                on_path[parent] = false;
                stack.pop();
                continue;
            };
            let child_at = top.next_child;
            top.next_child += 1;
            let transform = top.transform;
            let path = || format!("nodes[{parent}].children[{child_at}]");
            if on_path[child] {
                let from = stack.iter().position(|f| f.node == child).unwrap_or(0);
                let mut cycle: Vec<usize> = stack[from..].iter().map(|f| f.node).collect();
                cycle.push(child);
                return Err(GltfError::NodeCycle { path: path(), child, cycle });
            }
            enter(child, transform, &path, &mut stack)?;
            on_path[child] = true;
        }
    }
    Ok(out)
}
