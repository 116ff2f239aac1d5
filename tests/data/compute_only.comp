#version 460
// A compute shader: valid SPIR-V with no ray-tracing entry point, which raykit
// must refuse as a module. Compiled with:
//   glslangValidator --target-env vulkan1.2 -o compute_only.comp.spv compute_only.comp
layout(local_size_x = 1) in;
layout(set = 0, binding = 0) buffer Out { uint value; } out_buf;
void main() {
    out_buf.value = 42u;
}
