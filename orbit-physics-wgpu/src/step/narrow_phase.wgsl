// ---------------------------------------------------------------- narrow phase

struct Closest {
    dist: f32,
    normal: vec3<f32>,
    point: vec3<f32>,
}

// Signed distance from p to a box's surface, the outward normal there and the closest surface
// point.
fn closest_box(bpos: vec3<f32>, brot: vec4<f32>, size: vec3<f32>, p: vec3<f32>) -> Closest {
    var out: Closest;
    let pl = qrot(qconj(brot), p - bpos);
    let cl = clamp(pl, -size, size);
    let dv = pl - cl;
    let dl = length(dv);
    if dl > 1e-9 {
        out.dist = dl;
        out.normal = qrot(brot, dv / dl);
        out.point = bpos + qrot(brot, cl);
    } else {
        // Inside: leave through the nearest face.
        let gap = size - abs(pl);
        var axis = 0u;
        if gap.y < gap.x && gap.y <= gap.z {
            axis = 1u;
        } else if gap.z < gap.x && gap.z < gap.y {
            axis = 2u;
        }
        var nl = vec3<f32>(0.0);
        var face = pl;
        let sgn = select(-1.0, 1.0, pl[axis] >= 0.0);
        nl[axis] = sgn;
        face[axis] = sgn * size[axis];
        out.dist = -gap[axis];
        out.normal = qrot(brot, nl);
        out.point = bpos + qrot(brot, face);
    }
    return out;
}

// The same for the half-space z <= 0 of a plane's frame.
fn closest_plane(bpos: vec3<f32>, brot: vec4<f32>, p: vec3<f32>) -> Closest {
    var out: Closest;
    let nz = qrot(brot, vec3<f32>(0.0, 0.0, 1.0));
    let h = dot(p - bpos, nz);
    out.dist = h;
    out.normal = nz;
    out.point = p - h * nz;
    return out;
}

// The same for a sphere of radius r about c.
fn closest_sphere(c: vec3<f32>, r: f32, p: vec3<f32>) -> Closest {
    var out: Closest;
    let dv = p - c;
    let dl = length(dv);
    var n = vec3<f32>(0.0, 0.0, 1.0);
    if dl > 1e-9 {
        n = dv / dl;
    }
    out.dist = dl - r;
    out.normal = n;
    out.point = c + r * n;
    return out;
}

// The same for a z-aligned capsule (radius r, half segment length h).
fn closest_capsule(bpos: vec3<f32>, brot: vec4<f32>, r: f32, h: f32, p: vec3<f32>) -> Closest {
    let axis = qrot(brot, vec3<f32>(0.0, 0.0, 1.0));
    let t = clamp(dot(p - bpos, axis), -h, h);
    return closest_sphere(bpos + t * axis, r, p);
}

// Distance from p to a box (0 inside): pair culling against boxes.
fn box_gap(bpos: vec3<f32>, brot: vec4<f32>, size: vec3<f32>, p: vec3<f32>) -> f32 {
    let pl = qrot(qconj(brot), p - bpos);
    return length(max(abs(pl) - size, vec3<f32>(0.0)));
}

// Height of p above a plane (culling against planes).
fn plane_gap(bpos: vec3<f32>, brot: vec4<f32>, p: vec3<f32>) -> f32 {
    return dot(p - bpos, qrot(brot, vec3<f32>(0.0, 0.0, 1.0)));
}

fn add_contact(sep: f32, n: vec3<f32>, p: vec3<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    var i = nc;
    if nc == C_CAP {
        // Full: replace the shallowest contact if this one is deeper.
        var worst = 0u;
        for (var k = 1u; k < C_CAP; k++) {
            if c_sep[k] > c_sep[worst] {
                worst = k;
            }
        }
        if sep >= c_sep[worst] {
            return;
        }
        i = worst;
    } else {
        nc += 1u;
    }
    c_sep[i] = sep;
    c_n[i] = n;
    c_p[i] = p;
    c_ba[i] = ba;
    c_bb[i] = bb;
    c_mu[i] = mu;
    c_slot[i] = slot;
}

// A sphere of radius r about p (on body ba) against the surface `cl` found for it on body bb.
fn point_contact(cl: Closest, p: vec3<f32>, r: f32, ba: i32, bb: i32, mu: f32, slot: u32) {
    let sep = cl.dist - r;
    if sep >= MARGIN {
        return;
    }
    let pa = p - r * cl.normal;
    add_contact(sep, cl.normal, 0.5 * (pa + cl.point), ba, bb, mu, slot);
}

// Capsule a against box b: both end spheres, plus the segment point nearest the box when it
// lies inside the segment (slots slot, slot + 1, slot + 2).
fn capsule_box(apos: vec3<f32>, arot: vec4<f32>, ra: f32, ha: f32, bpos: vec3<f32>, brot: vec4<f32>, bsize: vec3<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    let axis = qrot(arot, vec3<f32>(0.0, 0.0, 1.0));
    let e0 = apos - ha * axis;
    let e1 = apos + ha * axis;
    point_contact(closest_box(bpos, brot, bsize, e0), e0, ra, ba, bb, mu, slot);
    point_contact(closest_box(bpos, brot, bsize, e1), e1, ra, ba, bb, mu, slot + 1u);
    // The segment point nearest the box, by alternating projections.
    var t = 0.0;
    for (var it = 0u; it < 4u; it++) {
        let pt = apos + t * axis;
        let pl = qrot(qconj(brot), pt - bpos);
        let cb = bpos + qrot(brot, clamp(pl, -bsize, bsize));
        t = clamp(dot(cb - apos, axis), -ha, ha);
    }
    if abs(t) < 0.95 * ha {
        let pm = apos + t * axis;
        point_contact(closest_box(bpos, brot, bsize, pm), pm, ra, ba, bb, mu, slot + 2u);
    }
}

// Capsule a against a plane: both end spheres.
fn capsule_plane(apos: vec3<f32>, arot: vec4<f32>, ra: f32, ha: f32, bpos: vec3<f32>, brot: vec4<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    let axis = qrot(arot, vec3<f32>(0.0, 0.0, 1.0));
    let e0 = apos - ha * axis;
    let e1 = apos + ha * axis;
    point_contact(closest_plane(bpos, brot, e0), e0, ra, ba, bb, mu, slot);
    point_contact(closest_plane(bpos, brot, e1), e1, ra, ba, bb, mu, slot + 1u);
}

// Capsule a against a capsule b (hb = 0: a sphere): the closest points of the two segments.
fn capsule_capsule(apos: vec3<f32>, arot: vec4<f32>, ra: f32, ha: f32, bpos: vec3<f32>, brot: vec4<f32>, rb: f32, hb: f32, ba: i32, bb: i32, mu: f32, slot: u32) {
    let axis = qrot(arot, vec3<f32>(0.0, 0.0, 1.0));
    let baxis = qrot(brot, vec3<f32>(0.0, 0.0, 1.0)) * hb;
    let d1 = 2.0 * ha * axis;
    let d2 = 2.0 * baxis;
    let p1 = apos - ha * axis;
    let p2 = bpos - baxis;
    let rr = p1 - p2;
    let aa = dot(d1, d1);
    let ee = dot(d2, d2);
    let ff = dot(d2, rr);
    let cc = dot(d1, rr);
    let bbd = dot(d1, d2);
    let den = aa * ee - bbd * bbd;
    var s = 0.0;
    if den > 1e-12 {
        s = clamp((bbd * ff - cc * ee) / den, 0.0, 1.0);
    }
    var t = 0.0;
    if ee > 1e-12 {
        t = (bbd * s + ff) / ee;
        if t < 0.0 {
            t = 0.0;
            s = clamp(-cc / aa, 0.0, 1.0);
        } else if t > 1.0 {
            t = 1.0;
            s = clamp((bbd - cc) / aa, 0.0, 1.0);
        }
    }
    let ca = p1 + s * d1;
    let cbp = p2 + t * d2;
    let dv = ca - cbp;
    let dl = length(dv);
    var n = vec3<f32>(0.0, 0.0, 1.0);
    if dl > 1e-9 {
        n = dv / dl;
    }
    let sep = dl - ra - rb;
    if sep < MARGIN {
        let pa = ca - ra * n;
        let pb = cbp + rb * n;
        add_contact(sep, n, 0.5 * (pa + pb), ba, bb, mu, slot);
    }
}

fn box_vertex(k: u32, size: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        select(-size.x, size.x, (k & 1u) != 0u),
        select(-size.y, size.y, (k & 2u) != 0u),
        select(-size.z, size.z, (k & 4u) != 0u),
    );
}

// Box a against a plane: its 8 vertices.
fn box_plane(apos: vec3<f32>, arot: vec4<f32>, asize: vec3<f32>, bpos: vec3<f32>, brot: vec4<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    for (var k = 0u; k < 8u; k++) {
        let v = apos + qrot(arot, box_vertex(k, asize));
        point_contact(closest_plane(bpos, brot, v), v, 0.0, ba, bb, mu, slot + k);
    }
}

// Box a's 8 vertices against box b (slots slot .. slot + 7); b's bounding radius `rb` skips
// vertices too far from b to touch it.
fn box_vertices_in_box(apos: vec3<f32>, arot: vec4<f32>, asize: vec3<f32>, bpos: vec3<f32>, brot: vec4<f32>, bsize: vec3<f32>, rb: f32, ba: i32, bb: i32, mu: f32, slot: u32) {
    for (var k = 0u; k < 8u; k++) {
        let v = apos + qrot(arot, box_vertex(k, asize));
        if distance(v, bpos) <= rb + MARGIN {
            point_contact(closest_box(bpos, brot, bsize, v), v, 0.0, ba, bb, mu, slot + k);
        }
    }
}

struct ShapePose {
    pos: vec3<f32>,
    rot: vec4<f32>,
}

// Where a fixed shape at env-frame position p is in the kernel's frame.
fn fixed_pos(p: vec3<f32>) -> vec3<f32> {
    if SHIFTED {
        return p - shift;
    }
    return p;
}

// False only if a sphere (c, r) is farther than the margin from fixed shape s.
fn near_fixed(s: u32, c: vec3<f32>, r: f32) -> bool {
    let e = GEO_SHAPES + 4u * s;
    let pos = fixed_pos(geo[e].xyz);
    let rot = geo[e + 1u];
    let size = geo[e + 2u];
    let kind = u32(geo[e + 3u].x);
    if kind == 2u {
        return box_gap(pos, rot, size.xyz, c) <= r + MARGIN;
    }
    if kind == 3u {
        return plane_gap(pos, rot, c) <= r + MARGIN;
    }
    return distance(c, pos) <= size.w + r + MARGIN;
}

// False only if two boxes are separated by more than the margin along one of their six face
// normals (a conservative separating-axis test).
fn boxes_near(apos: vec3<f32>, arot: vec4<f32>, asize: vec3<f32>, bpos: vec3<f32>, brot: vec4<f32>, bsize: vec3<f32>) -> bool {
    let ra = qmat(arot);
    let rb = qmat(brot);
    // b's axes in a's frame, and the centre offset in both frames.
    let r = transpose(ra) * rb;
    let t = bpos - apos;
    let ta = transpose(ra) * t;
    let tb = transpose(rb) * t;
    let ar = mat3x3<f32>(abs(r[0]), abs(r[1]), abs(r[2]));
    // Extent of b along a's axes, of a along b's axes.
    let eb = ar * bsize;
    let ea = transpose(ar) * asize;
    return all(abs(ta) <= asize + eb + vec3<f32>(MARGIN)) && all(abs(tb) <= bsize + ea + vec3<f32>(MARGIN));
}

// Whether the scene has a pair of kind code `code` (a's kind × 4 + b's): the cases of the others
// are constant-false.
fn has_pair_kind(code: u32) -> bool {
    return (PAIR_KINDS & (1u << code)) != 0u;
}

// False only if shapes a and b (at pa and pb, of bounding radii ra and rb) are farther apart
// than the margin; fa or fb is a fixed shape's index in the geometry table (its exact geometry
// is tested), -1 for a moving one.
fn pair_near(pa: vec3<f32>, ra: f32, fa: i32, pb: vec3<f32>, rb: f32, fb: i32) -> bool {
    if fb >= 0 {
        return near_fixed(u32(fb), pa, ra);
    }
    if fa >= 0 {
        return near_fixed(u32(fa), pb, rb);
    }
    return distance(pa, pb) <= ra + rb + MARGIN;
}

// The contacts of shape a (at pa; size and bounding radius sa; on body code ba) against shape
// b, by their kinds' code (a's kind × 4 + b's, a's not above b's).
fn collide_shapes(code: u32, pa: ShapePose, pb: ShapePose, sa: vec4<f32>, sb: vec4<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    switch code {
        case 0u: {
            if has_pair_kind(0u) {
                point_contact(closest_sphere(pb.pos, sb.x, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
            }
        }
        case 1u: {
            if has_pair_kind(1u) {
                point_contact(closest_capsule(pb.pos, pb.rot, sb.x, sb.y, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
            }
        }
        case 2u: {
            if has_pair_kind(2u) {
                point_contact(closest_box(pb.pos, pb.rot, sb.xyz, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
            }
        }
        case 3u: {
            if has_pair_kind(3u) {
                point_contact(closest_plane(pb.pos, pb.rot, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
            }
        }
        case 4u, 5u: {
            if has_pair_kind(4u) || has_pair_kind(5u) {
                // A sphere's half length is 0.
                capsule_capsule(pa.pos, pa.rot, sa.x, sa.y, pb.pos, pb.rot, sb.x, sb.y, ba, bb, mu, slot);
            }
        }
        case 6u: {
            if has_pair_kind(6u) {
                capsule_box(pa.pos, pa.rot, sa.x, sa.y, pb.pos, pb.rot, sb.xyz, ba, bb, mu, slot);
            }
        }
        case 7u: {
            if has_pair_kind(7u) {
                capsule_plane(pa.pos, pa.rot, sa.x, sa.y, pb.pos, pb.rot, ba, bb, mu, slot);
            }
        }
        case 10u: {
            if has_pair_kind(10u) {
                if !boxes_near(pa.pos, pa.rot, sa.xyz, pb.pos, pb.rot, sb.xyz) {
                    return;
                }
                box_vertices_in_box(pa.pos, pa.rot, sa.xyz, pb.pos, pb.rot, sb.xyz, sb.w, ba, bb, mu, slot);
                // b's vertices against a, the roles swapped.
                box_vertices_in_box(pb.pos, pb.rot, sb.xyz, pa.pos, pa.rot, sa.xyz, sa.w, bb, ba, mu, slot + 8u);
            }
        }
        case 11u: {
            if has_pair_kind(11u) {
                box_plane(pa.pos, pa.rot, sa.xyz, pb.pos, pb.rot, ba, bb, mu, slot);
            }
        }
        default: {}
    }
}
