// The root's velocity after turn t, from its owner, through workgroup memory (8 envs of 4
// threads, a slot of 6 floats per env and turn, so no slot is rewritten before all have read).
var<workgroup> xr: array<f32, 192>;

fn exchange(slot: u32, t: u32, owner: bool, vr: vec3<f32>, wr: vec3<f32>) -> mat2x3<f32> {
    let b = (slot * 4u + t) * 6u;
    if owner {
        xr[b] = vr.x;
        xr[b + 1u] = vr.y;
        xr[b + 2u] = vr.z;
        xr[b + 3u] = wr.x;
        xr[b + 4u] = wr.y;
        xr[b + 5u] = wr.z;
    }
    workgroupBarrier();
    return mat2x3<f32>(vec3<f32>(xr[b], xr[b + 1u], xr[b + 2u]), vec3<f32>(xr[b + 3u], xr[b + 4u], xr[b + 5u]));
}
