// ---------------------------------------------------------------- bindings

// The step kernel's buffers, the same for every form of the kernel.

struct Params {
    substeps: u32,
    // With no substeps: 1 to publish only the envs whose fresh input has REPUBLISH added
    // (the others keep their published state untouched), 0 to publish every env.
    only_marked: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read_write> st: array<f32>;
@group(0) @binding(1) var<storage, read> inp: array<f32>;
@group(0) @binding(2) var<storage, read_write> warm: array<f32>;
@group(0) @binding(3) var<uniform> params: Params;
// Buffer offsets that depend on the number of envs (see layout.rs), so one compiled kernel
// serves every env count of a scene.
@group(0) @binding(4) var<storage, read> lay: array<u32>;
// The scene's geometry table (compile.rs, `GeometryTable`): the same for every env.
@group(0) @binding(5) var<uniform> geo: array<vec4<f32>, GEO_LEN>;
