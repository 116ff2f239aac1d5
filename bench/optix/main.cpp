// raykit-optix: the OptiX twin of raykit-bench's `primary` and `path` suites.
//
//   raykit-optix primary|path SCENE OUT [--launches N] [--warmup N] [--module FILE] [--ias 0|1]
//       [--gas-build fast-trace|fast-build|neither]
//
// Reads the scene raykit-bench wrote (SCENE, see `Scene files` below), builds a
// compacted GAS (OPTIX_BUILD_FLAG_PREFER_FAST_TRACE) — with `--ias 1` also an
// IAS of one identity instance over it, traced as Vulkan traces (a top level
// over a bottom level), else the GAS alone (ALLOW_SINGLE_GAS) — links the programs of
// primary.optixir or path.optixir (next to this executable, or --module), and
// launches N times after the warm-up launches, each launch timed by CUDA events
// around optixLaunch. Writes OUT.img (the last launch's output: RGBA8 pixels as
// u32, or the accumulation buffer as 4 f32 per pixel) and OUT.json (the launch
// times and what was built). Exits non-zero with a message on any error.
//
// Scene files (little-endian): u32 magic 0x54504f52 ("ROPT"), u32 version 1,
// u32 kind (1 primary, 2 path), then
// * primary: u32 width, height, vertex count, index count; f32×15 cam_eye,
//   cam_u, cam_v, cam_w, background; f32×3 per vertex; u32 per index.
// * path: u32 width, height, samples, max_depth, group count, triangle count;
//   f32×12 cam_eye, cam_u, cam_v, cam_w; f32×12 light corner, v1, v2, emission;
//   per group u32 first_triangle, u32 triangles, f32×3 emission, f32×3 albedo;
//   f32×9 per triangle (vertices); f32×3 per triangle (normals).
#include <cuda_runtime.h>
#include <optix.h>
#include <optix_function_table_definition.h>
#include <optix_stack_size.h>
#include <optix_stubs.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "shared.h"

namespace {

struct Failure : std::runtime_error {
    using std::runtime_error::runtime_error;
};

void check_cuda(cudaError_t e, const char* what) {
    if (e != cudaSuccess) {
        throw Failure(std::string(what) + ": " + cudaGetErrorName(e) + " (" + cudaGetErrorString(e) + ")");
    }
}

void check_optix(OptixResult r, const char* what, const char* log = nullptr) {
    if (r != OPTIX_SUCCESS) {
        std::string msg = std::string(what) + ": " + optixGetErrorName(r) + " (" + optixGetErrorString(r) + ")";
        if (log != nullptr && log[0] != 0) {
            msg += "\n" + std::string(log);
        }
        throw Failure(msg);
    }
}

#define CUDA(call) check_cuda((call), #call)
#define OPTIX(call) check_optix((call), #call)

char g_log[8192];
size_t g_log_size = sizeof(g_log);

#define OPTIX_LOG(call)                        \
    do {                                       \
        g_log_size = sizeof(g_log);            \
        g_log[0] = 0;                          \
        check_optix((call), #call, g_log);     \
    } while (0)

std::vector<char> read_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) {
        throw Failure("cannot open " + path);
    }
    return std::vector<char>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// A cursor over the scene file.
struct Reader {
    const std::vector<char>& data;
    size_t at = 0;
    template <typename T>
    T get() {
        if (at + sizeof(T) > data.size()) {
            throw Failure("the scene file ends early");
        }
        T v;
        std::memcpy(&v, data.data() + at, sizeof(T));
        at += sizeof(T);
        return v;
    }
    float3 f3() {
        float x = get<float>(), y = get<float>(), z = get<float>();
        return make_float3(x, y, z);
    }
    template <typename T>
    std::vector<T> array(size_t n) {
        if (n > (data.size() - at) / sizeof(T)) {
            throw Failure("the scene file ends early");
        }
        std::vector<T> v(n);
        std::memcpy(v.data(), data.data() + at, n * sizeof(T));
        at += n * sizeof(T);
        return v;
    }
};

template <typename T>
CUdeviceptr upload(const std::vector<T>& v) {
    void* p = nullptr;
    CUDA(cudaMalloc(&p, std::max<size_t>(v.size() * sizeof(T), 4)));
    CUDA(cudaMemcpy(p, v.data(), v.size() * sizeof(T), cudaMemcpyHostToDevice));
    return reinterpret_cast<CUdeviceptr>(p);
}

CUdeviceptr upload_bytes(const void* bytes, size_t n) {
    void* p = nullptr;
    CUDA(cudaMalloc(&p, n));
    CUDA(cudaMemcpy(p, bytes, n, cudaMemcpyHostToDevice));
    return reinterpret_cast<CUdeviceptr>(p);
}

void context_log(unsigned int level, const char* tag, const char* message, void*) {
    if (level <= 2) {
        std::fprintf(stderr, "[optix %u][%s] %s\n", level, tag, message);
    }
}

// A built, compacted GAS.
struct Gas {
    OptixTraversableHandle handle = 0;
    CUdeviceptr buffer = 0;
    size_t built_bytes = 0;
    size_t compacted_bytes = 0;
    double build_ms = 0.0;
};

Gas build_gas(OptixDeviceContext ctx, std::vector<OptixBuildInput>& inputs, unsigned int preference) {
    OptixAccelBuildOptions options = {};
    options.buildFlags = preference | OPTIX_BUILD_FLAG_ALLOW_COMPACTION;
    options.operation = OPTIX_BUILD_OPERATION_BUILD;
    OptixAccelBufferSizes sizes = {};
    OPTIX(optixAccelComputeMemoryUsage(ctx, &options, inputs.data(), (unsigned int)inputs.size(), &sizes));
    void *temp = nullptr, *output = nullptr, *compacted_size = nullptr;
    CUDA(cudaMalloc(&temp, sizes.tempSizeInBytes));
    CUDA(cudaMalloc(&output, sizes.outputSizeInBytes));
    CUDA(cudaMalloc(&compacted_size, sizeof(uint64_t)));
    OptixAccelEmitDesc emit = {};
    emit.type = OPTIX_PROPERTY_TYPE_COMPACTED_SIZE;
    emit.result = reinterpret_cast<CUdeviceptr>(compacted_size);
    Gas gas;
    cudaEvent_t start, stop;
    CUDA(cudaEventCreate(&start));
    CUDA(cudaEventCreate(&stop));
    CUDA(cudaEventRecord(start, 0));
    OPTIX(optixAccelBuild(ctx, 0, &options, inputs.data(), (unsigned int)inputs.size(),
                          reinterpret_cast<CUdeviceptr>(temp), sizes.tempSizeInBytes,
                          reinterpret_cast<CUdeviceptr>(output), sizes.outputSizeInBytes, &gas.handle, &emit, 1));
    CUDA(cudaEventRecord(stop, 0));
    CUDA(cudaEventSynchronize(stop));
    float ms = 0.0f;
    CUDA(cudaEventElapsedTime(&ms, start, stop));
    gas.build_ms = ms;
    uint64_t compacted = 0;
    CUDA(cudaMemcpy(&compacted, compacted_size, sizeof(compacted), cudaMemcpyDeviceToHost));
    gas.built_bytes = sizes.outputSizeInBytes;
    if (compacted < sizes.outputSizeInBytes) {
        void* small = nullptr;
        CUDA(cudaMalloc(&small, compacted));
        OPTIX(optixAccelCompact(ctx, 0, gas.handle, reinterpret_cast<CUdeviceptr>(small), compacted, &gas.handle));
        CUDA(cudaDeviceSynchronize());
        CUDA(cudaFree(output));
        gas.buffer = reinterpret_cast<CUdeviceptr>(small);
        gas.compacted_bytes = compacted;
    } else {
        gas.buffer = reinterpret_cast<CUdeviceptr>(output);
        gas.compacted_bytes = sizes.outputSizeInBytes;
    }
    CUDA(cudaFree(temp));
    CUDA(cudaFree(compacted_size));
    CUDA(cudaEventDestroy(start));
    CUDA(cudaEventDestroy(stop));
    return gas;
}

// An IAS of one identity instance over `gas` (what Vulkan always traces: a
// top level over a bottom level). Not compacted: one instance.
struct Ias {
    OptixTraversableHandle handle = 0;
    CUdeviceptr buffer = 0;
    CUdeviceptr instances = 0;
};

Ias build_ias(OptixDeviceContext ctx, OptixTraversableHandle gas) {
    OptixInstance instance = {};
    const float identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    std::memcpy(instance.transform, identity, sizeof(identity));
    instance.instanceId = 0;
    instance.sbtOffset = 0;
    instance.visibilityMask = 255;
    instance.flags = OPTIX_INSTANCE_FLAG_NONE;
    instance.traversableHandle = gas;
    Ias ias;
    ias.instances = upload_bytes(&instance, sizeof(instance));
    OptixBuildInput input = {};
    input.type = OPTIX_BUILD_INPUT_TYPE_INSTANCES;
    input.instanceArray.instances = ias.instances;
    input.instanceArray.numInstances = 1;
    OptixAccelBuildOptions options = {};
    options.buildFlags = OPTIX_BUILD_FLAG_PREFER_FAST_TRACE;
    options.operation = OPTIX_BUILD_OPERATION_BUILD;
    OptixAccelBufferSizes sizes = {};
    OPTIX(optixAccelComputeMemoryUsage(ctx, &options, &input, 1, &sizes));
    void *temp = nullptr, *output = nullptr;
    CUDA(cudaMalloc(&temp, sizes.tempSizeInBytes));
    CUDA(cudaMalloc(&output, sizes.outputSizeInBytes));
    OPTIX(optixAccelBuild(ctx, 0, &options, &input, 1, reinterpret_cast<CUdeviceptr>(temp), sizes.tempSizeInBytes,
                          reinterpret_cast<CUdeviceptr>(output), sizes.outputSizeInBytes, &ias.handle, nullptr, 0));
    CUDA(cudaDeviceSynchronize());
    CUDA(cudaFree(temp));
    ias.buffer = reinterpret_cast<CUdeviceptr>(output);
    return ias;
}

// One program group of `kind` with entry points in `module` (null names: none).
OptixProgramGroup program_group(OptixDeviceContext ctx, OptixModule module, OptixProgramGroupKind kind,
                                const char* entry) {
    OptixProgramGroupOptions options = {};
    OptixProgramGroupDesc desc = {};
    desc.kind = kind;
    if (kind == OPTIX_PROGRAM_GROUP_KIND_RAYGEN) {
        desc.raygen.module = module;
        desc.raygen.entryFunctionName = entry;
    } else if (kind == OPTIX_PROGRAM_GROUP_KIND_MISS) {
        desc.miss.module = module;
        desc.miss.entryFunctionName = entry;
    } else {
        desc.hitgroup.moduleCH = module;
        desc.hitgroup.entryFunctionNameCH = entry;
    }
    OptixProgramGroup group = nullptr;
    OPTIX_LOG(optixProgramGroupCreate(ctx, &desc, 1, &options, g_log, &g_log_size, &group));
    return group;
}

template <typename T>
struct __align__(OPTIX_SBT_RECORD_ALIGNMENT) Record {
    __align__(OPTIX_SBT_RECORD_ALIGNMENT) char header[OPTIX_SBT_RECORD_HEADER_SIZE];
    T data;
};

struct Empty {};

template <typename T>
Record<T> record(OptixProgramGroup group, const T& data) {
    Record<T> r;
    std::memset(&r, 0, sizeof(r));
    OPTIX(optixSbtRecordPackHeader(group, &r));
    r.data = data;
    return r;
}

// The linked programs: module, groups (raygen first), pipeline.
struct Programs {
    OptixModule module = nullptr;
    std::vector<OptixProgramGroup> groups;
    OptixPipeline pipeline = nullptr;
};

Programs link(OptixDeviceContext ctx, const std::string& module_path, unsigned int payloads, bool ias,
              const std::vector<std::pair<OptixProgramGroupKind, const char*>>& entries) {
    std::vector<char> code = read_file(module_path);
    OptixModuleCompileOptions module_options = {};
    module_options.maxRegisterCount = OPTIX_COMPILE_DEFAULT_MAX_REGISTER_COUNT;
    module_options.optLevel = OPTIX_COMPILE_OPTIMIZATION_DEFAULT;
    module_options.debugLevel = OPTIX_COMPILE_DEBUG_LEVEL_NONE;
    OptixPipelineCompileOptions pipeline_options = {};
    pipeline_options.usesMotionBlur = 0;
    pipeline_options.traversableGraphFlags =
        ias ? OPTIX_TRAVERSABLE_GRAPH_FLAG_ALLOW_SINGLE_LEVEL_INSTANCING : OPTIX_TRAVERSABLE_GRAPH_FLAG_ALLOW_SINGLE_GAS;
    pipeline_options.numPayloadValues = (int)payloads;
    pipeline_options.numAttributeValues = 2;
    pipeline_options.exceptionFlags = OPTIX_EXCEPTION_FLAG_NONE;
    pipeline_options.pipelineLaunchParamsVariableName = "params";
    pipeline_options.usesPrimitiveTypeFlags = OPTIX_PRIMITIVE_TYPE_FLAGS_TRIANGLE;
    Programs p;
    OPTIX_LOG(optixModuleCreate(ctx, &module_options, &pipeline_options, code.data(), code.size(), g_log,
                                &g_log_size, &p.module));
    for (const auto& e : entries) {
        p.groups.push_back(program_group(ctx, p.module, e.first, e.second));
    }
    OptixPipelineLinkOptions link_options = {};
    link_options.maxTraceDepth = 1;
    OPTIX_LOG(optixPipelineCreate(ctx, &pipeline_options, &link_options, p.groups.data(),
                                  (unsigned int)p.groups.size(), g_log, &g_log_size, &p.pipeline));
    OptixStackSizes stack = {};
    for (OptixProgramGroup g : p.groups) {
        OPTIX(optixUtilAccumulateStackSizes(g, &stack, p.pipeline));
    }
    unsigned int from_traversal = 0, from_state = 0, continuation = 0;
    OPTIX(optixUtilComputeStackSizes(&stack, 1, 0, 0, &from_traversal, &from_state, &continuation));
    OPTIX(optixPipelineSetStackSize(p.pipeline, from_traversal, from_state, continuation, ias ? 2 : 1));
    return p;
}

struct Timing {
    std::vector<double> launch_ms;
};

// `warmup` + `launches` launches of `pipeline`, each timed by CUDA events.
template <typename P>
Timing launch(OptixPipeline pipeline, const OptixShaderBindingTable& sbt, const P& params, unsigned int width,
              unsigned int height, int warmup, int launches) {
    CUdeviceptr d_params = upload_bytes(&params, sizeof(P));
    cudaStream_t stream;
    CUDA(cudaStreamCreate(&stream));
    cudaEvent_t start, stop;
    CUDA(cudaEventCreate(&start));
    CUDA(cudaEventCreate(&stop));
    Timing t;
    for (int i = 0; i < warmup + launches; i++) {
        CUDA(cudaEventRecord(start, stream));
        OPTIX(optixLaunch(pipeline, stream, d_params, sizeof(P), &sbt, width, height, 1));
        CUDA(cudaEventRecord(stop, stream));
        CUDA(cudaEventSynchronize(stop));
        float ms = 0.0f;
        CUDA(cudaEventElapsedTime(&ms, start, stop));
        if (i >= warmup) {
            t.launch_ms.push_back(ms);
        }
    }
    CUDA(cudaGetLastError());
    CUDA(cudaEventDestroy(start));
    CUDA(cudaEventDestroy(stop));
    CUDA(cudaStreamDestroy(stream));
    CUDA(cudaFree(reinterpret_cast<void*>(d_params)));
    return t;
}

double median(std::vector<double> v) {
    if (v.empty()) {
        return 0.0;
    }
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void write_file(const std::string& path, const void* data, size_t n) {
    std::ofstream f(path, std::ios::binary);
    if (!f) {
        throw Failure("cannot write " + path);
    }
    f.write(static_cast<const char*>(data), (std::streamsize)n);
    if (!f) {
        throw Failure("cannot write " + path);
    }
}

std::string json_numbers(const std::vector<double>& v) {
    std::ostringstream s;
    s.precision(9);
    s << "[";
    for (size_t i = 0; i < v.size(); i++) {
        s << (i ? ", " : "") << v[i];
    }
    s << "]";
    return s.str();
}

std::string device_name() {
    cudaDeviceProp prop;
    CUDA(cudaGetDeviceProperties(&prop, 0));
    return prop.name;
}

void write_report(const std::string& out, const char* suite, unsigned int width, unsigned int height,
                  const Gas& gas, bool ias, const Timing& t, double rays, const std::string& extra) {
    int driver = 0;
    CUDA(cudaDriverGetVersion(&driver));
    std::ostringstream s;
    s.precision(9);
    s << "{\n  \"suite\": \"" << suite << "\",\n  \"device\": \"" << device_name() << "\",\n"
      << "  \"optix_version\": " << OPTIX_VERSION << ",\n  \"cuda_driver\": " << driver << ",\n"
      << "  \"width\": " << width << ",\n  \"height\": " << height << ",\n"
      << "  \"gas_bytes\": " << gas.built_bytes << ",\n  \"gas_compacted_bytes\": " << gas.compacted_bytes << ",\n"
      << "  \"gas_build_ms\": " << gas.build_ms << ",\n"
      << "  \"traversable\": \"" << (ias ? "ias" : "gas") << "\",\n"
      << "  \"rays_per_launch\": " << rays << ",\n"
      << "  \"launch_ms\": " << json_numbers(t.launch_ms) << ",\n"
      << "  \"median_ms\": " << median(t.launch_ms) << extra << "\n}\n";
    std::string text = s.str();
    write_file(out + ".json", text.data(), text.size());
}

struct Options {
    std::string suite, scene, out, module;
    int launches = 20;
    int warmup = 3;
    bool ias = false;
    // OPTIX_BUILD_FLAG_PREFER_FAST_TRACE (default), _PREFER_FAST_BUILD or none.
    unsigned int preference = OPTIX_BUILD_FLAG_PREFER_FAST_TRACE;
};

std::string exe_dir(const char* argv0) {
    std::string p = argv0;
    size_t slash = p.find_last_of('/');
    return slash == std::string::npos ? std::string(".") : p.substr(0, slash);
}

void header(Reader& r, uint32_t kind) {
    if (r.get<uint32_t>() != 0x54504f52u) {
        throw Failure("not a raykit-bench scene file (magic)");
    }
    if (r.get<uint32_t>() != 1) {
        throw Failure("unknown scene file version");
    }
    if (r.get<uint32_t>() != kind) {
        throw Failure(kind == 1 ? "not a primary-ray scene" : "not a path-tracer scene");
    }
}

void run_primary(OptixDeviceContext ctx, const Options& o) {
    std::vector<char> file = read_file(o.scene);
    Reader r{file};
    header(r, 1);
    const uint32_t width = r.get<uint32_t>(), height = r.get<uint32_t>();
    const uint32_t vertex_count = r.get<uint32_t>(), index_count = r.get<uint32_t>();
    PrimaryParams params = {};
    params.size = make_uint2(width, height);
    params.cam_eye = r.f3();
    params.cam_u = r.f3();
    params.cam_v = r.f3();
    params.cam_w = r.f3();
    PrimaryMissData miss = {r.f3()};
    std::vector<float> vertices = r.array<float>(size_t(vertex_count) * 3);
    std::vector<uint32_t> indices = r.array<uint32_t>(index_count);
    if (width == 0 || height == 0 || index_count % 3 != 0 || index_count == 0) {
        throw Failure("bad primary-ray scene sizes");
    }

    CUdeviceptr d_vertices = upload(vertices), d_indices = upload(indices);
    const unsigned int flags[1] = {OPTIX_GEOMETRY_FLAG_DISABLE_ANYHIT};
    std::vector<OptixBuildInput> inputs(1);
    OptixBuildInput& input = inputs[0];
    input = {};
    input.type = OPTIX_BUILD_INPUT_TYPE_TRIANGLES;
    input.triangleArray.vertexFormat = OPTIX_VERTEX_FORMAT_FLOAT3;
    input.triangleArray.vertexStrideInBytes = 12;
    input.triangleArray.numVertices = vertex_count;
    input.triangleArray.vertexBuffers = &d_vertices;
    input.triangleArray.indexFormat = OPTIX_INDICES_FORMAT_UNSIGNED_INT3;
    input.triangleArray.indexStrideInBytes = 12;
    input.triangleArray.numIndexTriplets = index_count / 3;
    input.triangleArray.indexBuffer = d_indices;
    input.triangleArray.flags = flags;
    input.triangleArray.numSbtRecords = 1;
    Gas gas = build_gas(ctx, inputs, o.preference);
    Ias ias;
    if (o.ias) {
        ias = build_ias(ctx, gas.handle);
    }
    params.handle = o.ias ? ias.handle : gas.handle;

    Programs p = link(ctx, o.module, 3, o.ias,
                      {{OPTIX_PROGRAM_GROUP_KIND_RAYGEN, "__raygen__rg"},
                       {OPTIX_PROGRAM_GROUP_KIND_MISS, "__miss__ms"},
                       {OPTIX_PROGRAM_GROUP_KIND_HITGROUP, "__closesthit__ch"}});
    Record<Empty> rg = record(p.groups[0], Empty{});
    Record<PrimaryMissData> ms = record(p.groups[1], miss);
    Record<Empty> hg = record(p.groups[2], Empty{});
    OptixShaderBindingTable sbt = {};
    sbt.raygenRecord = upload_bytes(&rg, sizeof(rg));
    sbt.missRecordBase = upload_bytes(&ms, sizeof(ms));
    sbt.missRecordStrideInBytes = sizeof(ms);
    sbt.missRecordCount = 1;
    sbt.hitgroupRecordBase = upload_bytes(&hg, sizeof(hg));
    sbt.hitgroupRecordStrideInBytes = sizeof(hg);
    sbt.hitgroupRecordCount = 1;

    const size_t pixels = size_t(width) * height;
    void* image = nullptr;
    CUDA(cudaMalloc(&image, pixels * 4));
    CUDA(cudaMemset(image, 0, pixels * 4));
    params.image = static_cast<unsigned int*>(image);
    Timing t = launch(p.pipeline, sbt, params, width, height, o.warmup, o.launches);
    std::vector<uint32_t> host(pixels);
    CUDA(cudaMemcpy(host.data(), image, pixels * 4, cudaMemcpyDeviceToHost));
    write_file(o.out + ".img", host.data(), pixels * 4);
    write_report(o.out, "primary", width, height, gas, o.ias, t, double(pixels), "");
}

void run_path(OptixDeviceContext ctx, const Options& o) {
    std::vector<char> file = read_file(o.scene);
    Reader r{file};
    header(r, 2);
    const uint32_t width = r.get<uint32_t>(), height = r.get<uint32_t>();
    const uint32_t samples = r.get<uint32_t>(), max_depth = r.get<uint32_t>();
    const uint32_t group_count = r.get<uint32_t>(), triangle_count = r.get<uint32_t>();
    PathParams params = {};
    params.size = make_uint2(width, height);
    params.subframe = 0;
    params.samples = samples;
    params.max_depth = max_depth;
    params.row_offset = 0;
    params.cam_eye = r.f3();
    params.cam_u = r.f3();
    params.cam_v = r.f3();
    params.cam_w = r.f3();
    PathRaygenData light = {};
    light.corner = r.f3();
    light.v1 = r.f3();
    light.v2 = r.f3();
    light.emission = r.f3();
    if (width == 0 || height == 0 || group_count == 0 || group_count > 64) {
        throw Failure("bad path-tracer scene sizes");
    }
    std::vector<PathHitData> materials(group_count);
    for (PathHitData& m : materials) {
        m = {};
        m.first_triangle = r.get<uint32_t>();
        uint32_t triangles = r.get<uint32_t>();
        m.pad = triangles;  // kept here until the build inputs are made
        m.emission = r.f3();
        m.albedo = r.f3();
        if (uint64_t(m.first_triangle) + triangles > triangle_count) {
            throw Failure("a material group reaches past the triangles");
        }
    }
    std::vector<float> vertices = r.array<float>(size_t(triangle_count) * 9);
    std::vector<float> normals = r.array<float>(size_t(triangle_count) * 3);

    CUdeviceptr d_vertices = upload(vertices);
    params.normals = reinterpret_cast<const float*>(upload(normals));
    // One build input per material group, as raykit's one geometry per group.
    std::vector<CUdeviceptr> vertex_pointers(group_count);
    const unsigned int flags[1] = {OPTIX_GEOMETRY_FLAG_DISABLE_ANYHIT};
    std::vector<OptixBuildInput> inputs(group_count);
    for (uint32_t g = 0; g < group_count; g++) {
        vertex_pointers[g] = d_vertices + size_t(materials[g].first_triangle) * 36;
        OptixBuildInput& input = inputs[g];
        input = {};
        input.type = OPTIX_BUILD_INPUT_TYPE_TRIANGLES;
        input.triangleArray.vertexFormat = OPTIX_VERTEX_FORMAT_FLOAT3;
        input.triangleArray.vertexStrideInBytes = 12;
        input.triangleArray.numVertices = materials[g].pad * 3;
        input.triangleArray.vertexBuffers = &vertex_pointers[g];
        input.triangleArray.flags = flags;
        input.triangleArray.numSbtRecords = 1;
    }
    Gas gas = build_gas(ctx, inputs, o.preference);
    Ias ias;
    if (o.ias) {
        ias = build_ias(ctx, gas.handle);
    }
    params.handle = o.ias ? ias.handle : gas.handle;
    for (PathHitData& m : materials) {
        m.pad = 0;
    }

    Programs p = link(ctx, o.module, 10, o.ias,
                      {{OPTIX_PROGRAM_GROUP_KIND_RAYGEN, "__raygen__rg"},
                       {OPTIX_PROGRAM_GROUP_KIND_MISS, "__miss__ms"},
                       {OPTIX_PROGRAM_GROUP_KIND_MISS, "__miss__ms_shadow"},
                       {OPTIX_PROGRAM_GROUP_KIND_HITGROUP, "__closesthit__ch"},
                       {OPTIX_PROGRAM_GROUP_KIND_HITGROUP, "__closesthit__ch_shadow"}});
    Record<PathRaygenData> rg = record(p.groups[0], light);
    std::vector<Record<Empty>> miss = {record(p.groups[1], Empty{}), record(p.groups[2], Empty{})};
    // Per group: the radiance record, then the shadow record (SBT stride 2).
    std::vector<Record<PathHitData>> hits;
    for (const PathHitData& m : materials) {
        hits.push_back(record(p.groups[3], m));
        hits.push_back(record(p.groups[4], PathHitData{}));
    }
    OptixShaderBindingTable sbt = {};
    sbt.raygenRecord = upload_bytes(&rg, sizeof(rg));
    sbt.missRecordBase = upload(miss);
    sbt.missRecordStrideInBytes = sizeof(Record<Empty>);
    sbt.missRecordCount = 2;
    sbt.hitgroupRecordBase = upload(hits);
    sbt.hitgroupRecordStrideInBytes = sizeof(Record<PathHitData>);
    sbt.hitgroupRecordCount = (unsigned int)hits.size();

    const size_t pixels = size_t(width) * height;
    void* accum = nullptr;
    CUDA(cudaMalloc(&accum, pixels * 16));
    CUDA(cudaMemset(accum, 0, pixels * 16));
    params.accum = static_cast<float4*>(accum);
    // Every launch is subframe 0 with `samples` paths: it overwrites the
    // accumulation buffer, as the bench's raykit launches do.
    Timing t = launch(p.pipeline, sbt, params, width, height, o.warmup, o.launches);
    std::vector<float> host(pixels * 4);
    CUDA(cudaMemcpy(host.data(), accum, pixels * 16, cudaMemcpyDeviceToHost));
    write_file(o.out + ".img", host.data(), pixels * 16);
    double rays = 0.0;
    for (size_t i = 0; i < pixels; i++) {
        rays += host[i * 4 + 3];
    }
    std::ostringstream extra;
    extra << ",\n  \"samples\": " << samples << ",\n  \"max_depth\": " << max_depth;
    write_report(o.out, "path", width, height, gas, o.ias, t, rays, extra.str());
}

Options parse(int argc, char** argv) {
    if (argc < 4) {
        throw Failure(
            "usage: raykit-optix primary|path SCENE OUT [--launches N] [--warmup N] [--module FILE] [--ias 0|1] "
            "[--gas-build fast-trace|fast-build|neither]");
    }
    Options o;
    o.suite = argv[1];
    o.scene = argv[2];
    o.out = argv[3];
    if (o.suite != "primary" && o.suite != "path") {
        throw Failure("unknown suite " + o.suite + " (primary or path)");
    }
    for (int i = 4; i < argc; i++) {
        std::string a = argv[i];
        if (i + 1 >= argc) {
            throw Failure(a + " needs a value");
        }
        std::string v = argv[++i];
        if (a == "--launches") {
            o.launches = std::max(1, std::atoi(v.c_str()));
        } else if (a == "--warmup") {
            o.warmup = std::max(0, std::atoi(v.c_str()));
        } else if (a == "--gas-build") {
            if (v == "fast-trace") {
                o.preference = OPTIX_BUILD_FLAG_PREFER_FAST_TRACE;
            } else if (v == "fast-build") {
                o.preference = OPTIX_BUILD_FLAG_PREFER_FAST_BUILD;
            } else if (v == "neither") {
                o.preference = OPTIX_BUILD_FLAG_NONE;
            } else {
                throw Failure("--gas-build takes fast-trace, fast-build or neither");
            }
        } else if (a == "--ias") {
            o.ias = v == "1";
        } else if (a == "--module") {
            o.module = v;
        } else {
            throw Failure("unknown option " + a);
        }
    }
    if (o.module.empty()) {
        o.module = exe_dir(argv[0]) + "/" + o.suite + ".optixir";
        std::ifstream probe(o.module);
        if (!probe) {
            o.module = exe_dir(argv[0]) + "/" + o.suite + ".ptx";
        }
    }
    return o;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        Options o = parse(argc, argv);
        CUDA(cudaFree(nullptr));
        OPTIX(optixInit());
        OptixDeviceContextOptions options = {};
        options.logCallbackFunction = context_log;
        options.logCallbackLevel = 4;
        OptixDeviceContext ctx = nullptr;
        OPTIX(optixDeviceContextCreate(nullptr, &options, &ctx));
        if (o.suite == "primary") {
            run_primary(ctx, o);
        } else {
            run_path(ctx, o);
        }
        OPTIX(optixDeviceContextDestroy(ctx));
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raykit-optix: %s\n", e.what());
        return 1;
    }
}
