// The root's velocity after turn t, from its owner, by a broadcast within the env's quad of
// threads (subgroup operations).
fn exchange(slot: u32, t: u32, owner: bool, vr: vec3<f32>, wr: vec3<f32>) -> mat2x3<f32> {
    switch t {
        case 0u: {
            return mat2x3<f32>(quadBroadcast(vr, 0u), quadBroadcast(wr, 0u));
        }
        case 1u: {
            return mat2x3<f32>(quadBroadcast(vr, 1u), quadBroadcast(wr, 1u));
        }
        case 2u: {
            return mat2x3<f32>(quadBroadcast(vr, 2u), quadBroadcast(wr, 2u));
        }
        default: {
            return mat2x3<f32>(quadBroadcast(vr, 3u), quadBroadcast(wr, 3u));
        }
    }
}
