// ---------------------------------------------------------------- pair loop

// The narrow phase as a loop over the geometry table's groups of pairs, for the kernel forms
// with one thread per env: the bodies' poses are in arrays indexed at run time (`bpos`,
// `brot`, filled by `copy_body_poses`).

// Where shape s is now.
fn shape_pose(s: u32) -> ShapePose {
    let e = GEO_SHAPES + 4u * s;
    let b = i32(geo[e + 3u].z);
    var out: ShapePose;
    if b < 0 {
        out.pos = fixed_pos(geo[e].xyz);
        out.rot = geo[e + 1u];
    } else {
        out.pos = bpos[b] + qrot(brot[b], geo[e].xyz);
        out.rot = qmul(brot[b], geo[e + 1u]);
    }
    return out;
}

// The bounding sphere (centre, radius) of group side `side` if it is a moving body; `w < 0`
// for a fixed shape.
fn side_sphere(side: i32) -> vec4<f32> {
    if side < 0 {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let sph = geo[GEO_BODIES + u32(side)];
    return vec4<f32>(bpos[side] + qrot(brot[side], sph.xyz), sph.w);
}

// False only if a sphere (c, r) is farther than the margin from group side `side`, whose
// bounding sphere (from `side_sphere`) is `sph`.
fn near_side(c: vec3<f32>, r: f32, side: i32, sph: vec4<f32>) -> bool {
    if side < 0 {
        return near_fixed(u32(-1 - side), c, r);
    }
    return distance(c, sph.xyz) <= r + sph.w + MARGIN;
}

// The contacts of pair k (shapes a and b, a's kind code not above b's; a is at `pa` and
// has passed the test against the group's second side).
fn collide_pair(k: u32, pa: ShapePose) {
    let pr = geo[GEO_PAIRS + k];
    let a = u32(pr.x);
    let b = u32(pr.y);
    let slot = u32(pr.z);
    let ea = GEO_SHAPES + 4u * a;
    let eb = GEO_SHAPES + 4u * b;
    let pb = shape_pose(b);
    let sa = geo[ea + 2u];
    let sb = geo[eb + 2u];
    let ia = geo[ea + 3u];
    let ib = geo[eb + 3u];
    // Bounding spheres (or a fixed shape's exact geometry) farther apart than the margin: no
    // contact can come of this pair. A fixed b is the group's second side, which `collide`
    // has already tested a against.
    if ia.z >= 0.0 && ib.z >= 0.0 {
        if distance(pa.pos, pb.pos) > sa.w + sb.w + MARGIN {
            return;
        }
    } else if ia.z < 0.0 && !near_fixed(a, pb.pos, sb.w) {
        return;
    }
    let ba = i32(geo[ea].w);
    let bb = i32(geo[eb].w);
    // MuJoCo's rule: the higher priority's friction, else the larger one.
    var mu: f32;
    if ia.y > ib.y {
        mu = friction(a);
    } else if ib.y > ia.y {
        mu = friction(b);
    } else {
        mu = max(friction(a), friction(b));
    }
    collide_shapes(u32(ia.x) * 4u + u32(ib.x), pa, pb, sa, sb, ba, bb, mu, slot);
}

// Contacts of every shape pair that can touch: a group of pairs between two bodies is skipped
// when the bodies' bounding spheres are apart, a shape of the group's first side when it is
// apart from the second side, then each pair by its shapes' bounds.
fn collide() {
    nc = 0u;
    copy_body_poses();
    for (var g = 0u; g < NG; g++) {
        if !group_here(g) {
            continue;
        }
        let grp = geo[GEO_GROUPS + g];
        let side_a = i32(grp.x);
        let side_b = i32(grp.y);
        let first = u32(grp.z);
        let count = u32(grp.w);
        let sph_b = side_sphere(side_b);
        if count > 1u {
            // A moving side's sphere against the other side (a fixed side exactly).
            let sph_a = side_sphere(side_a);
            var near_group: bool;
            if side_a >= 0 {
                near_group = near_side(sph_a.xyz, sph_a.w, side_b, sph_b);
            } else {
                near_group = near_side(sph_b.xyz, sph_b.w, side_a, sph_a);
            }
            if !near_group {
                continue;
            }
        }
        // Pairs of one group are ordered by their first shape: its pose and its test against
        // the second side serve all of them.
        var last = 0xFFFFFFFFu;
        var pa: ShapePose;
        var near = false;
        for (var k = first; k < first + count; k++) {
            let a = u32(geo[GEO_PAIRS + k].x);
            if a != last {
                last = a;
                pa = shape_pose(a);
                near = side_a < 0 || near_side(pa.pos, geo[GEO_SHAPES + 4u * a + 2u].w, side_b, sph_b);
            }
            if near {
                collide_pair(k, pa);
            }
        }
    }
}
