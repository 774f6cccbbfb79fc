#!/usr/bin/env python3
"""Generates orbit-assets/assets/franka_panda_rod.urdf from the Fancy Gym box-pushing parameters.

Usage (from the workspace root):

    python3 orbit-assets/tools/gen_franka_urdf.py > orbit-assets/assets/franka_panda_rod.urdf

The parameters are read from `franka_box_pushing_params.json` beside this script (the numbers of
Fancy Gym's `panda_rod.xml`, see its `_about`); another parameter file of the same layout may be
given as the only argument.

Needs Python 3 and numpy only; deterministic (fixed seeds), runs in about three minutes.

What it writes:
- kinematics from `robot.links` (`pos` and `compiled_quat_normalized` of each body in its parent,
  the quaternion converted exactly to URDF fixed-axis roll-pitch-yaw);
- inertials as given (`mass`, `com`, `inertia_full_in_body_frame` about the COM in body axes,
  written with inertial rpy = 0 so nothing is rotated or rounded);
- arm joints revolute about z with the XML ranges, effort limits from the actuator force ranges and
  velocity limits from `limits_used_by_env_code.q_dot_max`;
- fingers welded (fixed joints) at the opening MuJoCo settles to (0.00122 m each);
- collision primitives: per link one or two capsules fitted to the decimated convex hull (see
  `fit_capsules`), the rod cylinder, and one box per finger covering the finger hull's AABB.
"""

import itertools
import json
import math
import os
import sys

import numpy as np

FINGER_OPENING = 0.00122  # m per finger: where MuJoCo's finger-finger contacts push them in step 1
EFFORT = [87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0]  # panda_rod.xml's motor forcerange, N m
MISSING_WEIGHT = 2.0  # capsule fit: uncovered hull volume costs twice as much as excess volume
TWO_CAPSULE_GAIN = 0.9  # use two capsules only if that lowers the fit objective by >= 10 %
MC_SAMPLES = 10000  # optimisation sample (hull AABB grown by OPT_MARGIN)
OPT_MARGIN = 0.05  # m
STATS_SAMPLES = 400000  # sample for the reported volumes (AABB grown by STATS_MARGIN)
STATS_MARGIN = 0.1  # m, more than any capsule reaches beyond the hull
SOFT_EPS = 1e-3  # m, width of the smoothed inside/outside indicator used by the optimiser


def fmt(x):
    """Shortest text that reads back as the same double (>= 9 significant digits kept)."""
    x = float(x)
    if x == 0.0:
        return "0"
    return repr(x)


def vec(v):
    return " ".join(fmt(x) for x in v)


def quat_to_rpy(q):
    """URDF rpy (R = Rz(yaw) Ry(pitch) Rx(roll)) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(c) for c in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return mat_to_rpy(r)


def mat_to_rpy(r):
    sp = -r[2, 0]
    if abs(sp) > 1 - 1e-12:  # gimbal lock: put everything into yaw
        pitch = math.copysign(math.pi / 2, sp)
        return [0.0, pitch, math.atan2(-r[0, 1], r[1, 1])]
    return [
        math.atan2(r[2, 1], r[2, 2]),
        math.asin(sp),
        math.atan2(r[1, 0], r[0, 0]),
    ]


def clean(a, eps=1e-15):
    return [0.0 if abs(v) < eps else v for v in a]


# ---------------------------------------------------------------------------------------------
# Capsule fitting
# ---------------------------------------------------------------------------------------------


def hull_planes(p):
    """Supporting planes (n, d) with n·x <= d inside, by brute force over point triples."""
    idx = np.array(list(itertools.combinations(range(len(p)), 3)))
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    n = np.cross(b - a, c - a)
    length = np.linalg.norm(n, axis=1)
    ok = length > 1e-12
    n = n[ok] / length[ok, None]
    d = np.einsum("ij,ij->i", n, a[ok])
    s = p @ n.T - d
    pos = (s > 1e-9).any(0)
    neg = (s < -1e-9).any(0)
    keep = ~(pos & neg)
    sign = np.where(pos[keep], -1.0, 1.0)
    return n[keep] * sign[:, None], d[keep] * sign


def seg_dist(x, a, b):
    ab = b - a
    l2 = ab @ ab
    t = np.clip(((x - a) @ ab) / l2, 0.0, 1.0) if l2 > 0 else np.zeros(len(x))
    return np.linalg.norm(x - (a + t[:, None] * ab), axis=1)


def unpack(x):
    return [(x[i : i + 3], x[i + 3 : i + 6], abs(x[i + 6])) for i in range(0, len(x), 7)]


def pack(caps):
    return np.concatenate([np.concatenate([a, b, [r]]) for a, b, r in caps])


def capsule_volume(a, b, r):
    return math.pi * r * r * (np.linalg.norm(b - a) + 4.0 / 3.0 * r)


def nelder_mead(f, x0, step, iters=3000, tol=1e-10):
    n = len(x0)
    pts = [x0] + [x0 + np.eye(n)[i] * step for i in range(n)]
    vals = [f(p) for p in pts]
    for _ in range(iters):
        order = np.argsort(vals)
        pts = [pts[i] for i in order]
        vals = [vals[i] for i in order]
        if vals[-1] - vals[0] < tol:
            break
        c = np.mean(pts[:-1], axis=0)
        xr = c + (c - pts[-1])
        fr = f(xr)
        if fr < vals[0]:
            xe = c + 2 * (c - pts[-1])
            fe = f(xe)
            pts[-1], vals[-1] = (xe, fe) if fe < fr else (xr, fr)
        elif fr < vals[-2]:
            pts[-1], vals[-1] = xr, fr
        else:
            xc = c + 0.5 * (pts[-1] - c)
            fc = f(xc)
            if fc < vals[-1]:
                pts[-1], vals[-1] = xc, fc
            else:
                pts = [pts[0]] + [pts[0] + 0.5 * (q - pts[0]) for q in pts[1:]]
                vals = [vals[0]] + [f(q) for q in pts[1:]]
    i = int(np.argmin(vals))
    return pts[i], vals[i]


def pca_capsule(p):
    """Initial guess: segment along the principal axis between the 10/90 % projections, radius
    the median distance of the points from that axis."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c)
    d = vt[0]
    t = (p - c) @ d
    lo, hi = np.quantile(t, [0.1, 0.9])
    radial = np.linalg.norm((p - c) - np.outer(t, d), axis=1)
    return (c + lo * d, c + hi * d, float(np.median(radial)))


def fit_capsules(points, seed=0):
    """Fits one or two capsules to a convex hull given by its vertices.

    Rule: minimise  V(capsules \\ hull) + 2 · V(hull \\ capsules)  (Monte-Carlo volumes on a fixed
    sample of the hull's AABB grown by 5 cm, with the inside test smoothed over 1 mm so that
    Nelder–Mead can optimise it). Missing hull volume costs twice as much as excess volume, so
    the fit leans towards covering the hull without inflating to cover every corner. Starts: the
    PCA capsule, and for two capsules the PCA capsules of the two halves of the points split at
    the median along each link axis. Two capsules are used only if they lower the objective by
    at least 10 %.
    """
    planes_n, planes_d = hull_planes(points)
    lo = points.min(axis=0) - OPT_MARGIN
    hi = points.max(axis=0) + OPT_MARGIN
    rng = np.random.default_rng(seed)
    x = rng.uniform(lo, hi, (MC_SAMPLES, 3))
    box = float(np.prod(hi - lo))
    in_hull = (x @ planes_n.T - planes_d <= 0).all(axis=1)
    in_hull_f = in_hull.astype(float)

    def margin(caps):
        m = np.full(len(x), -1e9)
        for a, b, r in caps:
            m = np.maximum(m, r - seg_dist(x, a, b))
        return m

    def objective(v):
        c = 1.0 / (1.0 + np.exp(-np.clip(margin(unpack(v)) / SOFT_EPS, -50, 50)))
        return box * float(np.mean(c * (1 - in_hull_f) + MISSING_WEIGHT * (1 - c) * in_hull_f))

    def optimise(init):
        v, _ = nelder_mead(objective, pack(init), 0.01)
        v, val = nelder_mead(objective, v, 0.002)
        return unpack(v), val

    best1 = optimise([pca_capsule(points)])
    best2 = None
    centre = points.mean(axis=0)
    for axis in np.eye(3):
        t = (points - centre) @ axis
        lab = t > np.median(t)
        if min(lab.sum(), (~lab).sum()) < 4:
            continue
        res = optimise([pca_capsule(points[~lab]), pca_capsule(points[lab])])
        if best2 is None or res[1] < best2[1]:
            best2 = res
    caps = best2[0] if best2 and best2[1] < TWO_CAPSULE_GAIN * best1[1] else best1[0]

    lo = points.min(axis=0) - STATS_MARGIN
    hi = points.max(axis=0) + STATS_MARGIN
    box = float(np.prod(hi - lo))
    x = rng.uniform(lo, hi, (STATS_SAMPLES, 3))
    in_hull = (x @ planes_n.T - planes_d <= 0).all(axis=1)
    inside = margin(caps) >= 0
    stats = {
        "union_volume": box * float(inside.mean()),
        "hull_volume_mc": box * float(in_hull.mean()),
        "covered": float((inside & in_hull).sum() / in_hull.sum()),
        "sum_volume": sum(capsule_volume(*c) for c in caps),
        "vertex_excess_max": float(
            np.max(np.min([seg_dist(points, a, b) - r for a, b, r in caps], axis=0))
        ),
    }
    return caps, stats


def capsule_xml(a, b, r):
    d = b - a
    length = float(np.linalg.norm(d))
    centre = (a + b) / 2
    if length < 1e-6:
        return f'<geometry><sphere radius="{r:.5f}"/></geometry>', centre, [0.0, 0.0, 0.0]
    d = d / length
    if d[np.argmax(np.abs(d))] < 0:  # a capsule has no direction: pick the tidier sign
        d = -d
    # R = Ry(pitch) Rx(roll) maps +z onto d: d = (cos r sin p, -sin r, cos r cos p).
    roll = -math.asin(max(-1.0, min(1.0, d[1])))
    pitch = math.atan2(d[0], d[2])
    geom = f'<geometry><capsule radius="{r:.5f}" length="{length:.5f}"/></geometry>'
    return geom, centre, [roll, pitch, 0.0]


# ---------------------------------------------------------------------------------------------
# URDF writer
# ---------------------------------------------------------------------------------------------


def inertial_xml(mass, com, inertia, indent="    "):
    i = inertia
    return (
        f"{indent}<inertial>\n"
        f'{indent}  <origin xyz="{vec(com)}" rpy="0 0 0"/>\n'
        f'{indent}  <mass value="{fmt(mass)}"/>\n'
        f'{indent}  <inertia ixx="{fmt(i[0][0])}" ixy="{fmt(i[0][1])}" ixz="{fmt(i[0][2])}"'
        f' iyy="{fmt(i[1][1])}" iyz="{fmt(i[1][2])}" izz="{fmt(i[2][2])}"/>\n'
        f"{indent}</inertial>\n"
    )


def main():
    if len(sys.argv) > 2:
        sys.exit("usage: gen_franka_urdf.py [path/to/franka_box_pushing_params.json]")
    here = os.path.dirname(os.path.abspath(__file__))
    default = os.path.join(here, "franka_box_pushing_params.json")
    src = sys.argv[1] if len(sys.argv) == 2 else default
    with open(src) as f:
        params = json.load(f)
    robot = params["robot"]
    links = {l["name"]: l for l in robot["links"]}
    meshes = robot["collision_hulls"]["meshes"]
    xml_ranges = robot["limits_in_xml_joint_range"]
    vel_max = robot["limits_used_by_env_code"]["q_dot_max"]

    out = []
    w = out.append
    w('<?xml version="1.0"?>\n')
    w("<!--\n")
    w("  GENERATED FILE - do not edit by hand.\n")
    w("  Generator: orbit-assets/tools/gen_franka_urdf.py\n")
    w("  Source:    orbit-assets/tools/franka_box_pushing_params.json (Fancy Gym da1bced,\n")
    w("             fancy_gym/envs/mujoco/box_pushing/assets/panda_rod.xml, MuJoCo 2.3.3)\n")
    w("\n")
    w("  Franka Emika Panda with the Fancy Gym push rod. Frames, masses, COMs and full inertia\n")
    w("  tensors (about the COM, body axes) are the MuJoCo model's. Differences to the MJCF:\n")
    w("  - The two fingers are WELDED to the hand (fixed joints) at the opening MuJoCo settles to\n")
    w(f"    after the first control step ({FINGER_OPENING} m each; unactuated, no task role).\n")
    w("    Their tip bodies are kept as fixed child links with their (large, as written) inertias.\n")
    w("  - Collision meshes are replaced by primitives: per link one or two capsules fitted to the\n")
    w("    decimated convex hull (rule in gen_franka_urdf.py: fit_capsules; statistics below),\n")
    w("    one box per finger covering the finger hull's AABB (finger-tip pads not modelled\n")
    w("    separately; they lie inside that box), and the rod cylinder.\n")
    w("  - Joint velocity limits are the environment's q_dot_max; effort limits the actuators'\n")
    w("    force ranges (87 / 12 N m); position limits the XML ranges.\n")
    w("  - tcp (hand + 0.105 z) and rod_tip (rod + 0.2 z) are massless links on fixed joints.\n")
    w("-->\n")
    w('<robot name="panda_rod">\n')
    w("  <!--\n")
    w("    orbit-rs extension (ignored by other URDF readers): panda_link0 sits on the robot mount\n")
    w("    plate (franka_mount.ron); both are in collision group 2 (value 2) with mask !2 so\n")
    w("    that they never collide with each other.\n")
    w("  -->\n")
    w('  <orbit_collision_filter link="panda_link0" groups="2" mask="4294967293"/>\n')

    fit_report = []

    def collision_for_mesh(mesh):
        pts = np.array(meshes[mesh]["decimated_hull_points"], dtype=float)
        caps, st = fit_capsules(pts)
        hull = meshes[mesh]["hull_volume_m3"]
        fit_report.append(
            f"    {mesh:7s}: {len(caps)} capsule(s), radii "
            + ", ".join(f"{r:.4f}" for _, _, r in caps)
            + f" m; capsule volume {st['sum_volume']:.3e} m3 (union {st['union_volume']:.3e})"
            f" vs hull {hull:.3e} m3 = x{st['union_volume'] / hull:.2f};"
            f" covers {100 * st['covered']:.1f} % of the hull;"
            f" farthest hull vertex {1000 * max(st['vertex_excess_max'], 0):.1f} mm outside\n"
        )
        s = ""
        for a, b, r in caps:
            geom, centre, rpy = capsule_xml(a, b, r)
            s += (
                "    <collision>\n"
                f'      <origin xyz="{" ".join(f"{c:.5f}" for c in clean(centre, 5e-6))}"'
                f' rpy="{" ".join(f"{c:.6f}" for c in clean(rpy, 5e-7))}"/>\n'
                f"      {geom}\n"
                "    </collision>\n"
            )
        return s

    def link(name, inertial=True, collision="", comment=""):
        l = links.get(name)
        s = f'  <link name="{name}">\n'
        if comment:
            s += f"    <!-- {comment} -->\n"
        if inertial and l is not None and l["mass"] > 0:
            s += inertial_xml(l["mass"], l["com"], l["inertia_full_in_body_frame"])
        s += collision
        s += "  </link>\n"
        w(s)

    def joint(name, kind, parent, child, pos, quat=(1, 0, 0, 0), extra="", comment=""):
        s = f'  <joint name="{name}" type="{kind}">\n'
        if comment:
            s += f"    <!-- {comment} -->\n"
        rpy = clean(quat_to_rpy(quat))
        s += f'    <origin xyz="{vec(pos)}" rpy="{vec(rpy)}"/>\n'
        s += f'    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
        s += extra
        s += "  </joint>\n"
        w(s)

    # Arm.
    link("panda_link0", collision=collision_for_mesh("link0v"))
    for i in range(1, 8):
        name = f"panda_link{i}"
        l = links[name]
        lo, hi = xml_ranges[i - 1]
        extra = (
            '    <axis xyz="0 0 1"/>\n'
            f'    <limit lower="{fmt(lo)}" upper="{fmt(hi)}" effort="{fmt(EFFORT[i - 1])}"'
            f' velocity="{fmt(vel_max[i - 1])}"/>\n'
            '    <dynamics damping="0" friction="0"/>\n'
        )
        joint(l["joint"], "revolute", l["parent"], name, l["pos"], l["compiled_quat_normalized"], extra)
        link(name, collision=collision_for_mesh(l["collision_mesh"]))

    # Flange, hand, rod, tcp.
    for name, jname in [("panda_link8", "panda_joint8"), ("panda_hand", "panda_hand_joint")]:
        l = links[name]
        joint(jname, "fixed", l["parent"], name, l["pos"], l["compiled_quat_normalized"])
        coll = collision_for_mesh(l["collision_mesh"]) if l["collision_mesh"] else ""
        link(name, collision=coll)

    rod = robot["push_rod"]
    g = rod["geom"]
    joint("push_rod_joint", "fixed", rod["parent"], "push_rod", rod["body_pos"], rod["body_quat"])
    link(
        "push_rod",
        collision=(
            "    <collision>\n"
            f'      <origin xyz="{vec(g["pos_in_rod_frame"])}" rpy="0 0 0"/>\n'
            f'      <geometry><cylinder radius="{fmt(g["radius"])}"'
            f' length="{fmt(2 * g["half_length"])}"/></geometry>\n'
            "    </collision>\n"
        ),
        comment="mass/inertia: the MuJoCo cylinder at density 1000",
    )
    joint("rod_tip_joint", "fixed", "push_rod", "rod_tip", rod["rod_tip_site_pos_in_rod_frame"])
    link("rod_tip", inertial=False, comment="the MuJoCo site rod_tip (massless frame)")
    tcp = robot["tcp"]
    joint("panda_tcp_joint", "fixed", tcp["parent"], "tcp", tcp["pos"], tcp["quat"])
    link("tcp", inertial=False, comment="the MuJoCo body/site tcp (massless frame)")

    # Fingers, welded.
    fv = meshes["fingerv"]
    fmin, fmax = np.array(fv["aabb_min"]), np.array(fv["aabb_max"])
    half = (fmax - fmin) / 2
    for side, sign, jname, tip in [
        ("left", 1.0, "panda_finger_joint1", "finger_joint1_tip"),
        ("right", -1.0, "panda_finger_joint2", "finger_joint2_tip"),
    ]:
        name = f"panda_{side}finger"
        l = links[name]
        pos = np.array(l["pos"], dtype=float) + np.array([0.0, sign * FINGER_OPENING, 0.0])
        joint(
            jname,
            "fixed",
            l["parent"],
            name,
            pos,
            l["compiled_quat_normalized"],
            comment=(
                f"MJCF: slide joint along {'+' if sign > 0 else '-'}y of the hand, range [0, 0.04],"
                f" damping 10, unactuated; welded here at {FINGER_OPENING} m"
            ),
        )
        centre = (fmin + fmax) / 2
        if sign < 0:  # right finger mesh is rotated 180 deg about z
            centre = centre * np.array([-1.0, -1.0, 1.0])
        coll = (
            "    <collision>\n"
            f'      <origin xyz="{" ".join(f"{c:.6f}" for c in centre)}" rpy="0 0 0"/>\n'
            f'      <geometry><box size="{" ".join(f"{2 * h:.6f}" for h in half)}"/></geometry>\n'
            "    </collision>\n"
        )
        link(name, collision=coll, comment="collision: box covering the fingerv hull AABB")
        t = links[tip]
        joint(f"{tip}_joint", "fixed", name, tip, t["pos"], t["compiled_quat_normalized"])
        link(tip, comment="finger tip body of the MJCF (inertia 0.01 as written)")

    w(f"  <!--\n    Capsule fit per collision mesh (volumes by Monte Carlo, {STATS_SAMPLES} samples):\n")
    for line in fit_report:
        w(line)
    w("  -->\n")
    w("</robot>\n")
    sys.stdout.write("".join(out))


if __name__ == "__main__":
    main()
