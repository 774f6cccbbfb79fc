//! Jacobian windows: where a floating root's tree branches (an Ant's legs, a quadruped's), a
//! constraint row on one branch has non-zero Jacobian entries beyond the root's (which the rows
//! compute instead of storing, see `contact_root_vel`) only at that branch's dofs. Such a row
//! stores a window of those entries instead of every joint's, so that the solver's sweeps,
//! which are bound by the rows' bytes at many envs, read fewer of them.

use std::fmt::Write as _;

use super::Gen;
use crate::compile::CompiledScene;

/// The window of each branch: each subtree hanging from the floating root's link, and each
/// other (fixed-base) articulation.
#[derive(Debug, PartialEq)]
pub(super) struct JacobianWindows {
    /// Entries a window holds: the widest branch's span of dofs.
    pub width: usize,
    /// Each branch's first dof in its window (the window ends within the dofs).
    pub starts: Vec<usize>,
    /// Per link: its branch; `None` for the root's link and joint-less roots, which move no
    /// dof beyond the root's.
    pub link_branch: Vec<Option<usize>>,
    /// Per dof: its branch; `None` for the root's six.
    pub dof_branch: Vec<Option<usize>>,
}

/// Six bits of a contact's info hold its rows' branch.
const MAX_BRANCHES: usize = 64;

impl JacobianWindows {
    /// The windows of `scene`, whose rows store `nj` Jacobian entries from dof `j0` on. A
    /// branch is a subtree hanging from the floating root's link, or another (fixed-base)
    /// articulation. `None` where the rows leave out no floating root's entries (`j0 == 0`),
    /// where the tree has one branch or more than [`MAX_BRANCHES`], where two shapes on
    /// different branches can touch (self-collisions between legs: such a row needs two
    /// windows, and a branch per row in the sweeps costs more than the windows save), or where
    /// a window would hold more than half of a row's entries: each of its entries costs the
    /// sweeps a select per branch, which only pays where most of a row's bytes go (the
    /// Humanoid's widest branch, abdomen and legs, spans 15 of its 21 joint dofs).
    pub fn of(scene: &CompiledScene, j0: usize, nj: usize) -> Option<Self> {
        if j0 == 0 {
            return None;
        }
        let links = &scene.links;
        let root_link = |l: usize| links[l].free_root.is_some();
        // Each link's topmost ancestor below the floating root's link (or its own articulation
        // root): the branch's name, until numbered.
        let top: Vec<Option<usize>> = (0..links.len())
            .map(|l| {
                let mut at = l;
                while let Some(p) = links[at].parent {
                    if root_link(p) {
                        break;
                    }
                    at = p;
                }
                (!root_link(at)).then_some(at)
            })
            .collect();
        let mut names: Vec<usize> = Vec::new();
        let mut spans: Vec<(usize, usize)> = Vec::new();
        let mut dof_branch = vec![None; scene.dofs.len()];
        for (l, link) in links.iter().enumerate() {
            let (Some(name), Some(d)) = (top[l], link.dof) else {
                continue;
            };
            let s = names.iter().position(|&n| n == name).unwrap_or_else(|| {
                names.push(name);
                spans.push((d, d));
                names.len() - 1
            });
            spans[s] = (spans[s].0.min(d), spans[s].1.max(d));
            dof_branch[d] = Some(s);
        }
        let width = spans.iter().map(|(lo, hi)| hi - lo + 1).max()?;
        if names.len() < 2 || names.len() > MAX_BRANCHES || 2 * width > nj {
            return None;
        }
        let link_branch: Vec<Option<usize>> = top
            .iter()
            .map(|t| t.and_then(|name| names.iter().position(|&n| n == name)))
            .collect();
        let branch = |shape: usize| {
            let body = scene.shapes[shape].body?;
            link_branch.get(body).copied().flatten()
        };
        let crossing = scene
            .pairs
            .iter()
            .any(|p| match (branch(p.a), branch(p.b)) {
                (Some(a), Some(b)) => a != b,
                _ => false,
            });
        if crossing {
            return None;
        }
        let nd = scene.dofs.len();
        let starts = spans.iter().map(|&(lo, _)| lo.min(nd - width)).collect();
        Some(Self {
            width,
            starts,
            link_branch,
            dof_branch,
        })
    }
}

impl Gen<'_> {
    /// `row_branch(ba, bb)` (the branch of a contact between bodies `ba` and `bb`) and
    /// `dof_branch(d)` (a limit row's on dof `d`): with windows a branch's index, without them
    /// 0, which the rows' accessors then do not read.
    pub(super) fn row_branches(&mut self, windows: Option<&JacobianWindows>) {
        let Some(w) = windows else {
            self.line("// No Jacobian windows: every row stores all NJ entries.");
            self.line("fn row_branch(ba: i32, bb: i32) -> u32 { return 0u; }");
            self.line("fn dof_branch(d: u32) -> u32 { return 0u; }");
            self.line("");
            return;
        };
        self.line("const NO_BRANCH = 64u;");
        self.line(
            "// The branch that body b lies on; NO_BRANCH for the floating root's link, the static",
        );
        self.line("// world and free objects, which move no windowed dof.");
        self.open("fn body_branch(b: i32) -> u32");
        self.line("var s = NO_BRANCH;");
        for (l, s) in w.link_branch.iter().enumerate() {
            if let Some(s) = s {
                self.line(format!("s = select(s, {s}u, b == {l});"));
            }
        }
        self.line("return s;");
        self.close();
        self.line("");
        self.line(
            "// The branch of a contact's rows: the branch of its side that has one (no two shapes",
        );
        self.line(
            "// on different branches touch); with neither, any window, which then holds zeros.",
        );
        self.open("fn row_branch(ba: i32, bb: i32) -> u32");
        self.line("let s = min(body_branch(ba), body_branch(bb));");
        self.line("return select(s, 0u, s == NO_BRANCH);");
        self.close();
        self.line("");
        self.line("// The branch of joint dof d.");
        self.open("fn dof_branch(d: u32) -> u32");
        self.line("var s = 0u;");
        for (d, s) in w.dof_branch.iter().enumerate() {
            if let Some(s) = s.filter(|&s| s > 0) {
                self.line(format!("s = select(s, {s}u, d == {d}u);"));
            }
        }
        self.line("return s;");
        self.close();
        self.line("");
    }

    /// Lines storing the window of `jt` for the WGSL branch index `br`, entry `k` at `rj(k)`.
    pub(super) fn window_store(&mut self, w: &JacobianWindows, rj: &dyn Fn(usize) -> String) {
        for k in 0..w.width {
            let pick = window_pick(w, "jt", k);
            self.line(format!("{} = {pick};", rj(k)));
        }
    }
}

/// The expression of the window dot product with q̇ for the WGSL branch index `br`, entry `k`
/// of the row at `rj(k)`.
pub(super) fn window_dot(w: &JacobianWindows, rj: &dyn Fn(usize) -> String) -> String {
    let mut dot = String::from("0.0");
    for k in 0..w.width {
        write!(dot, " + {} * {}", rj(k), window_pick(w, "qd", k)).expect("write to string");
    }
    dot
}

/// `array[start + k]` for the start of branch `br`, as a chain of selects: each index stays a
/// constant, so the array stays in registers.
fn window_pick(w: &JacobianWindows, array: &str, k: usize) -> String {
    let mut pick = format!("{array}[{}]", w.starts[0] + k);
    for (s, start) in w.starts.iter().enumerate().skip(1) {
        pick = format!("select({pick}, {array}[{}], br == {s}u)", start + k);
    }
    pick
}

#[cfg(test)]
mod tests {
    use orbit_core::scene::{CollisionFilter, SceneCfg};

    use super::JacobianWindows;
    use crate::compile::CompiledScene;

    fn windows(scene: &CompiledScene) -> Option<JacobianWindows> {
        let nd = scene.dofs.len();
        JacobianWindows::of(scene, 6, nd - 6)
    }

    /// The Ant on the ground; with `touching`, its self-collisions on and every shape's filter
    /// open (its model's shapes collide with the ground only, as MuJoCo's do).
    fn ant(touching: bool) -> CompiledScene {
        let mut ant = orbit_conformance::standing_ant(0.6, &[]);
        ant.self_collisions = touching;
        let cfg = SceneCfg {
            env_spacing: 3.0,
            articulations: vec![ant],
            rigid_objects: vec![],
            static_objects: vec![orbit_conformance::ground(1.0)],
        };
        let mut desc = orbit_conformance::resolve(&cfg);
        if touching {
            for shape in desc.articulations[0]
                .model
                .links
                .iter_mut()
                .flat_map(|l| &mut l.shapes)
            {
                shape.filter = CollisionFilter {
                    groups: 1,
                    mask: u32::MAX,
                };
            }
        }
        CompiledScene::new(&desc).expect("compiles")
    }

    /// The Ant's four legs (hip, then ankle, each a link with one dof) are four windows of
    /// two entries, a quarter of the eight a row stores otherwise.
    #[test]
    fn the_ants_legs_are_windows_of_two_dofs() {
        let scene = ant(false);
        let w = windows(&scene).expect("the Ant's legs branch");
        assert_eq!((w.width, w.starts.clone()), (2, vec![6, 8, 10, 12]));
        let legs = [
            None,
            Some(0),
            Some(0),
            Some(1),
            Some(1),
            Some(2),
            Some(2),
            Some(3),
            Some(3),
        ];
        assert_eq!(w.link_branch, legs);
        assert_eq!(
            &w.dof_branch[..7],
            &[None, None, None, None, None, None, Some(0)]
        );
        // Without the root's entries left out, no windows.
        assert_eq!(JacobianWindows::of(&scene, 0, 14), None);
    }

    /// With self-collisions, one leg can touch another: a row then has entries on two legs,
    /// so the rows store them all.
    #[test]
    fn legs_that_touch_each_other_get_no_windows() {
        assert_eq!(windows(&ant(true)), None);
    }
}
