//! The thread-per-branch kernel's narrow phase: each lane's shape pairs
//! ([`Branches::lane_pairs`]) written out one after the other, with their kinds, sizes, bodies,
//! slots and local poses as literals selected by lane, and their frictions read once per
//! dispatch. The other forms loop over the geometry table (`step/pair_loop.wgsl`), with the
//! bodies' poses in arrays indexed at run time; on the Ant that loop took about a quarter of
//! the step (docs/experiments/ant-narrow-phase.md).

use glam::{Quat, Vec3};

use super::branch_threads::{Branches, lane_select};
use super::{Gen, f, q4, v3};
use crate::compile::{GeometryTable, ShapeKind};

/// One shape of a pair as the table describes it.
struct TableShape {
    /// Position: in the body's frame, or the env's for a fixed shape.
    pos: Vec3,
    rot: Quat,
    /// Size and bounding radius.
    size: [f32; 4],
    /// Body code: the body's index, −1 for a fixed shape.
    body: i64,
    kind: u32,
    priority: f32,
}

/// Shape `s` of the geometry table.
fn table_shape(geo: &GeometryTable, s: usize) -> TableShape {
    let e = geo.shapes + 4 * s;
    let [x, y, z, body] = geo.data[e];
    let [qx, qy, qz, qw] = geo.data[e + 1];
    TableShape {
        pos: Vec3::new(x, y, z),
        rot: Quat::from_xyzw(qx, qy, qz, qw),
        size: geo.data[e + 2],
        body: body as i64,
        kind: geo.data[e + 3][0] as u32,
        priority: geo.data[e + 3][1],
    }
}

/// Shapes a and b and the first contact slot of the geometry table's pair `k`.
fn table_pair(geo: &GeometryTable, k: usize) -> (usize, usize, u32) {
    let [a, b, slot, _] = geo.data[geo.pairs + k];
    (a as usize, b as usize, slot as u32)
}

/// The kinds' code of the geometry table's pair `k` (a's kind × 4 + b's), as `collide_shapes`
/// takes it.
fn pair_code(geo: &GeometryTable, k: usize) -> u32 {
    let (a, b, _) = table_pair(geo, k);
    table_shape(geo, a).kind * 4 + table_shape(geo, b).kind
}

impl Gen<'_> {
    /// The narrow phase of each lane's pairs (`collide`) and the frictions it uses
    /// (`load_frictions`, called with the state).
    pub(super) fn branch_narrow_phase(&mut self, br: &Branches) {
        let geo = &self.scene.geometry_table();
        let positions = pair_positions(br, |k| pair_code(geo, k));
        self.line("// This lane's friction of each of its pairs, for this env.");
        self.line(format!(
            "var<private> pair_mu: array<f32, {}>;",
            positions.len().max(1)
        ));
        self.open("fn load_frictions()");
        for (i, lanes) in positions.iter().enumerate() {
            let mu = pair_friction(geo, lanes);
            self.line(format!("pair_mu[{i}] = {mu};"));
        }
        self.close();
        self.line("");
        self.line("// This lane's contacts: its pairs in the geometry table's order.");
        self.open("fn collide()");
        self.line("nc = 0u;");
        // The geometry table is one of the kernel's bindings even where no pair reads it.
        self.line("_ = geo[0];");
        for (i, lanes) in positions.iter().enumerate() {
            self.pair_position(geo, br, i, lanes);
        }
        self.close();
        self.line("");
    }

    /// Emits the pair of each lane at position `i` of its list.
    fn pair_position(
        &mut self,
        geo: &GeometryTable,
        br: &Branches,
        i: usize,
        lanes: &[Option<usize>],
    ) {
        let shapes = |k: usize| {
            let (a, b, _) = table_pair(geo, k);
            (a, b)
        };
        let code = lane_select(&by_lane(lanes, |_, k| format!("{}u", pair_code(geo, k))));
        let on: Vec<usize> = (0..lanes.len()).filter(|&l| lanes[l].is_some()).collect();
        self.line(format!("// Pair {i} of each lane: kinds {code}."));
        if on.len() < 4 {
            let cond: Vec<String> = on.iter().map(|l| format!("lane == {l}u")).collect();
            self.open(format!("if {}", cond.join(" || ")));
        } else {
            self.open("");
        }
        for (name, second) in [("a", false), ("b", true)] {
            let shape = |k: usize| {
                let (a, b) = shapes(k);
                if second { b } else { a }
            };
            let (pos, rot) = shape_pose(geo, br, lanes, &shape);
            self.line(format!("let p{name} = ShapePose({pos}, {rot});"));
            let size = lane_select(&by_lane(lanes, |_, k| {
                let [x, y, z, r] = table_shape(geo, shape(k)).size;
                format!("vec4<f32>({}, {}, {}, {})", f(x), f(y), f(z), f(r))
            }));
            self.line(format!("let s{name} = {size};"));
        }
        let body = |second: bool| {
            lane_select(&by_lane(lanes, |_, k| {
                let (a, b) = shapes(k);
                table_shape(geo, if second { b } else { a })
                    .body
                    .to_string()
            }))
        };
        let slot = lane_select(&by_lane(lanes, |_, k| format!("{}u", table_pair(geo, k).2)));
        let call = format!(
            "collide_shapes({code}, pa, pb, sa, sb, {}, {}, pair_mu[{i}], {slot});",
            body(false),
            body(true)
        );
        // A sphere or capsule against a plane costs no more than the test that would skip it.
        let cheap = present(lanes).all(|k| {
            let (a, b) = shapes(k);
            table_shape(geo, b).kind == ShapeKind::Plane.code()
                && table_shape(geo, a).kind <= ShapeKind::Capsule.code()
        });
        if cheap {
            self.line(call);
        } else {
            // A fixed shape by its index (its exact geometry is tested), a moving one by −1.
            let fixed = |second: bool| {
                lane_select(&by_lane(lanes, |_, k| {
                    let (a, b) = shapes(k);
                    let s = if second { b } else { a };
                    let index = if table_shape(geo, s).body < 0 {
                        s as i64
                    } else {
                        -1
                    };
                    index.to_string()
                }))
            };
            self.open(format!(
                "if pair_near(pa.pos, sa.w, {}, pb.pos, sb.w, {})",
                fixed(false),
                fixed(true)
            ));
            self.line(call);
            self.close();
        }
        self.close();
    }
}

/// The friction of each lane's pair by MuJoCo's rule: the higher priority's, else the
/// larger.
fn pair_friction(geo: &GeometryTable, lanes: &[Option<usize>]) -> String {
    // Which of the pair's shapes, a and b, the rule reads.
    let reads = |k: usize| {
        let (a, b, _) = table_pair(geo, k);
        let (pa, pb) = (table_shape(geo, a).priority, table_shape(geo, b).priority);
        (pa >= pb, pb >= pa)
    };
    let rule = |reads: (bool, bool), a: &str, b: &str| match reads {
        (true, true) => format!("max(friction({a}), friction({b}))"),
        (true, false) => format!("friction({a})"),
        _ => format!("friction({b})"),
    };
    let rules: Vec<(bool, bool)> = present(lanes).map(reads).collect();
    if rules.iter().all(|&r| r == rules[0]) {
        // The same rule on every lane: one read of each side, its shape selected by lane.
        let side = |second: bool| {
            lane_select(&by_lane(lanes, |_, k| {
                let (a, b, _) = table_pair(geo, k);
                format!("{}u", if second { b } else { a })
            }))
        };
        return rule(rules[0], &side(false), &side(true));
    }
    lane_select(&by_lane(lanes, |_, k| {
        let (a, b, _) = table_pair(geo, k);
        rule(reads(k), &format!("{a}u"), &format!("{b}u"))
    }))
}

/// The pose (position, rotation) of one shape (`shape` of a pair) of each lane's pair: a
/// fixed shape's from its env-frame literals, a moving one's from its body's pose on the
/// lane (the root's link or a link of the lane's chain) and its local literals.
fn shape_pose(
    geo: &GeometryTable,
    br: &Branches,
    lanes: &[Option<usize>],
    shape: &dyn Fn(usize) -> usize,
) -> (String, String) {
    let table = |k: usize| table_shape(geo, shape(k));
    let lit_pos = lane_select(&by_lane(lanes, |_, k| v3(table(k).pos)));
    let lit_rot = lane_select(&by_lane(lanes, |_, k| q4(table(k).rot)));
    let fixed_on: Vec<usize> = (0..lanes.len())
        .filter(|&l| lanes[l].is_some_and(|k| table(k).body < 0))
        .collect();
    let moving_on = present(lanes).any(|k| table(k).body >= 0);
    if !moving_on {
        return (format!("fixed_pos({lit_pos})"), lit_rot);
    }
    // The body's pose on each lane: its chain's link or the root's.
    let body = |l: usize, k: usize, what: [&str; 2]| {
        let b = table(k).body;
        match br.chains[l].iter().position(|&x| x as i64 == b) {
            Some(j) => format!("{}[{j}]", what[0]),
            None => what[1].to_string(),
        }
    };
    let bp = lane_select(&by_lane(lanes, |l, k| body(l, k, ["lpos", "rpos"])));
    let bq = lane_select(&by_lane(lanes, |l, k| body(l, k, ["lrot", "rrot"])));
    let moving = (
        format!("{bp} + qrot({bq}, {lit_pos})"),
        format!("qmul({bq}, {lit_rot})"),
    );
    if fixed_on.is_empty() {
        return moving;
    }
    // Fixed on some lanes, moving on others: both, selected.
    let cond: Vec<String> = fixed_on.iter().map(|l| format!("lane == {l}u")).collect();
    let cond = cond.join(" || ");
    (
        format!("select({}, fixed_pos({lit_pos}), {cond})", moving.0),
        format!("select({}, {lit_rot}, {cond})", moving.1),
    )
}

/// `value(lane, pair)` for each lane, a lane without a pair taking the first lane's that has
/// one (its selects then add nothing).
fn by_lane(lanes: &[Option<usize>], value: impl Fn(usize, usize) -> String) -> Vec<String> {
    let values: Vec<Option<String>> = lanes
        .iter()
        .enumerate()
        .map(|(l, k)| k.map(|k| value(l, k)))
        .collect();
    let first = values.iter().flatten().next().cloned().unwrap_or_default();
    values
        .into_iter()
        .map(|v| v.unwrap_or_else(|| first.clone()))
        .collect()
}

/// The pairs of a position on the lanes that have one, in lane order.
fn present(lanes: &[Option<usize>]) -> impl Iterator<Item = usize> + '_ {
    lanes.iter().flatten().copied()
}

/// The lanes' pair lists side by side: entry `i` holds each lane's `i`-th pair, or `None` for a
/// lane with fewer. The lists are aligned at their starts or at their ends, whichever gives
/// fewer positions where lanes' pairs differ in kinds (`code`): such a position runs every
/// kind's code on every lane.
fn pair_positions(br: &Branches, code: impl Fn(usize) -> u32) -> Vec<Vec<Option<usize>>> {
    let len = br.lane_pairs.iter().map(Vec::len).max().unwrap_or(0);
    let align = |at_end: bool| -> Vec<Vec<Option<usize>>> {
        (0..len)
            .map(|i| {
                br.lane_pairs
                    .iter()
                    .map(|pairs| {
                        let skip = if at_end { len - pairs.len() } else { 0 };
                        i.checked_sub(skip).and_then(|j| pairs.get(j).copied())
                    })
                    .collect()
            })
            .collect()
    };
    let mixed = |positions: &[Vec<Option<usize>>]| {
        positions
            .iter()
            .filter(|lanes| {
                let mut codes = present(lanes).map(&code);
                let first = codes.next();
                codes.any(|c| Some(c) != first)
            })
            .count()
    };
    let (start, end) = (align(false), align(true));
    if mixed(&end) < mixed(&start) {
        end
    } else {
        start
    }
}
