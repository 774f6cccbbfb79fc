//! Rendered images against geometry: a sphere's silhouette has the pinhole camera's area, a
//! shadow falls where the light ray through the sphere's centre meets the floor, and the
//! box-pushing scene shows its box and its target where the camera projects them; videos come
//! out at the configured steps with one frame per env step.

use glam::{Quat, Vec3};
use orbit_core::math::Pose;
use orbit_core::physics::{PhysicsBackend, SimCfg, build_backend};
use orbit_core::scene::{
    CollisionFilter, Geometry, Marker, MarkerShape, Material, RigidBodyModel, SceneDesc, Shape,
    StaticObjectDesc, ViewerCfg, solid_inertial,
};
use orbit_physics_rapier as _;
use orbit_render::{Image, Renderer, VideoCfg, VideoRecorder};
use orbit_task_box_pushing as _;

/// A scene of static objects only, and a one-env CPU backend for it.
fn static_scene(shapes: &[(Geometry, Pose)]) -> (SceneDesc, Box<dyn PhysicsBackend>) {
    let static_objects = shapes
        .iter()
        .enumerate()
        .map(|(i, &(geometry, pose))| StaticObjectDesc {
            name: format!("object{i}"),
            pose,
            body: RigidBodyModel {
                name: format!("object{i}"),
                inertial: solid_inertial(&Geometry::Sphere { radius: 0.1 }, 1.0),
                shapes: vec![Shape {
                    geometry,
                    pose: Pose::default(),
                    material: Material::default(),
                    filter: CollisionFilter::default(),
                }],
            },
        })
        .collect();
    let desc = SceneDesc {
        env_spacing: 1.0,
        articulations: Vec::new(),
        rigid_objects: Vec::new(),
        static_objects,
    };
    let backend = build_backend(&desc, 1, &SimCfg::default()).unwrap_or_else(|e| panic!("{e}"));
    (desc, backend)
}

fn sphere_marker(center: Vec3, radius: f32) -> Marker {
    Marker {
        shape: MarkerShape::Geometry(Geometry::Sphere { radius }),
        pose: Pose::new(center, Quat::IDENTITY),
        color: [0.9, 0.9, 0.9],
        opacity: 1.0,
    }
}

fn luminance(p: [u8; 3]) -> f32 {
    p.iter().map(|&c| f32::from(c)).sum::<f32>() / 3.0
}

/// A sphere of radius r seen from distance d on the optical axis appears as a disc of radius
/// f·r/√(d² − r²) pixels (its silhouette cone has half-angle asin(r/d)). Counting pixel
/// centres inside a disc of ~2 400 pixels is exact to about 1 % (the lattice error of a circle).
#[test]
fn sphere_silhouette_has_the_pinhole_area() {
    let (desc, backend) = static_scene(&[]);
    let viewer = ViewerCfg {
        eye: (3.0, 0.0, 0.0),
        lookat: (0.0, 0.0, 0.0),
        fov_deg: 40.0,
        resolution: (320, 240),
        ..ViewerCfg::default()
    };
    let mut renderer = Renderer::new(&desc, &viewer, 1).unwrap();
    let (r, d) = (0.25f32, 3.0f32);
    let mut empty = renderer.new_image();
    renderer.render(backend.as_ref(), &[], &mut empty);
    let mut with_sphere = renderer.new_image();
    renderer.render(
        backend.as_ref(),
        &[sphere_marker(Vec3::ZERO, r)],
        &mut with_sphere,
    );
    let changed = (empty.rgb().chunks_exact(3))
        .zip(with_sphere.rgb().chunks_exact(3))
        .filter(|(a, b)| a != b)
        .count() as f32;
    let rho = renderer.camera().focal() * r / (d * d - r * r).sqrt();
    let expected = std::f32::consts::PI * rho * rho;
    let rel = (changed - expected).abs() / expected;
    println!("silhouette {changed} px, pinhole disc {expected:.1} px (rel. error {rel:.4})");
    assert!(rel < 0.015, "{changed} vs {expected}");
}

/// Under a directional light, a sphere's shadow on the floor is centred where the light ray
/// through its centre meets the floor: there the floor gets only the ambient share of its
/// colour, AMBIENT / (AMBIENT + DIFFUSE·L_z) ≈ 0.374 of a lit patch on the same checker colour.
#[test]
fn shadow_falls_along_the_light_direction() {
    let floor = (Geometry::Plane, Pose::default());
    let (desc, backend) = static_scene(&[floor]);
    let viewer = ViewerCfg {
        eye: (0.0, -2.0, 2.0),
        lookat: (0.0, 0.0, 0.0),
        fov_deg: 60.0,
        resolution: (200, 150),
        ..ViewerCfg::default()
    };
    let mut renderer = Renderer::new(&desc, &viewer, 1).unwrap();
    let center = Vec3::new(0.0, 0.0, 0.4);
    let mut image = renderer.new_image();
    renderer.render(backend.as_ref(), &[sphere_marker(center, 0.1)], &mut image);
    // The light direction the renderer uses, measured from its own shading: the brightest
    // possible floor patch is lit at AMBIENT + DIFFUSE·L_z; use the documented direction.
    let light = Vec3::new(0.3464, -0.2598, 0.9014);
    let shadow = center - light * (center.z / light.z);
    // A lit floor point on a square of the same checker colour (0.25 m squares): one full
    // checker period (0.5 m) along x from the shadow's centre.
    let lit = shadow + Vec3::new(-0.5, 0.0, 0.0);
    let at = |p: Vec3| {
        let (x, y, _) = renderer.camera().project(p).unwrap();
        image.pixel(x as u32, y as u32)
    };
    let (shadow_px, lit_px) = (luminance(at(shadow)), luminance(at(lit)));
    let ratio = shadow_px / lit_px;
    let expected = 0.35 / (0.35 + 0.65 * light.z);
    println!("shadow / lit = {ratio:.3} (expected {expected:.3})");
    assert!((ratio - expected).abs() < 0.02, "{ratio} vs {expected}");
    // Without the sphere the same patch is lit.
    let mut bare = renderer.new_image();
    renderer.render(backend.as_ref(), &[], &mut bare);
    let (x, y, _) = renderer.camera().project(shadow).unwrap();
    assert!((luminance(bare.pixel(x as u32, y as u32)) / lit_px - 1.0).abs() < 0.02);
}

fn box_pushing(num_envs: usize) -> orbit_managers::ManagerBasedRlEnv {
    let overrides = [
        format!("num_envs={num_envs}"),
        // A target in the open part of the table, in front of the arm as the camera sees it.
        "commands.target.params.fixed=Some([0.5, -0.3, -0.01, 1.0, 0.0, 0.0, 0.0])".to_string(),
    ];
    let mut env = orbit_managers::make("BoxPushing-Torque-Franka-v0", &overrides)
        .unwrap_or_else(|e| panic!("{e}"));
    env.reset().unwrap();
    env
}

/// The box (red by default) is where the camera projects its top plate's centre, and the
/// translucent target ghost tints the table green where the target's centre projects.
#[test]
fn box_pushing_frame_shows_the_box_and_its_target() {
    let env = box_pushing(2);
    let mut renderer = Renderer::new(&env.scene().desc, &env.cfg.base.viewer, 2).unwrap();
    let mut image: Image = renderer.new_image();
    let markers = env.debug_markers(0);
    assert_eq!(markers.len(), 1, "one target marker");
    renderer.render(env.scene().backend.as_ref(), &markers, &mut image);
    let backend = env.scene().backend.as_ref();
    let box_center = backend.rigid_object(0).pos[0];
    let (x, y, _) = renderer.camera().project(box_center).unwrap();
    let [r, g, b] = image.pixel(x as u32, y as u32);
    assert!(
        r > g + 40 && r > b + 40,
        "box pixel {:?} should be red",
        [r, g, b]
    );
    let (x, y, _) = renderer
        .camera()
        .project(Vec3::new(0.5, -0.3, -0.01))
        .unwrap();
    let [r, g, b] = image.pixel(x as u32, y as u32);
    assert!(
        g > r + 20 && g > b + 20,
        "target pixel {:?} should be green",
        [r, g, b]
    );
    // A bad viewer setting is refused with the field named.
    let mut viewer = env.cfg.base.viewer.clone();
    viewer.colors.insert("boxx".into(), (1.0, 0.0, 0.0));
    let err = Renderer::new(&env.scene().desc, &viewer, 2).err().unwrap();
    assert!(err.to_string().contains("colors.boxx") && err.to_string().contains("\"box\""));
    viewer.colors.clear();
    viewer.env_index = 2;
    let err = Renderer::new(&env.scene().desc, &viewer, 2).err().unwrap();
    assert!(err.to_string().contains("env_index"), "{err}");
}

/// With a 3-step interval and 2-step videos, 8 env steps give videos starting at steps 0, 3
/// and 6, two frames each, each shown for one env step (0.02 s = 2 hundredths).
#[test]
fn videos_start_every_interval_with_one_frame_per_step() {
    let mut env = box_pushing(1);
    let dir = std::env::temp_dir().join(format!("orbit-render-video-{}", std::process::id()));
    let cfg = VideoCfg {
        dir: dir.clone(),
        length: 2,
        interval: Some(3),
    };
    let empty = VideoCfg {
        length: 0,
        ..cfg.clone()
    };
    let err = VideoRecorder::new(&env, empty).err().unwrap().to_string();
    assert!(
        err.starts_with("video: expected a positive video length"),
        "{err}"
    );
    env.set_step_observer(Some(Box::new(VideoRecorder::new(&env, cfg).unwrap())));
    let zero = vec![0.0; env.action_dim()];
    for _ in 0..8 {
        env.step(&zero).unwrap();
    }
    drop(env);
    for step in [0, 3, 6] {
        let path = orbit_render::video_path(&dir, step);
        let mut opts = gif::DecodeOptions::new();
        opts.set_color_output(gif::ColorOutput::RGBA);
        let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        let mut dec = opts.read_info(file).unwrap();
        let mut frames = 0;
        while let Some(f) = dec.read_next_frame().unwrap() {
            assert_eq!((f.width, f.height, f.delay), (320, 240, 2));
            frames += 1;
        }
        assert_eq!(frames, 2, "{path:?}");
    }
    let count = std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(count, 3);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Pixels are independent, so a frame is the same on one thread as on several.
#[test]
fn frames_do_not_depend_on_the_thread_count() {
    let env = box_pushing(1);
    let mut renderer = Renderer::new(&env.scene().desc, &env.cfg.base.viewer, 1).unwrap();
    let markers = env.debug_markers(0);
    renderer.place(env.scene().backend.as_ref(), &markers);
    let mut frames = Vec::new();
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut image = renderer.new_image();
        pool.install(|| renderer.draw(&mut image));
        frames.push(image);
    }
    assert!(frames[0] == frames[1], "the frames differ");
}
