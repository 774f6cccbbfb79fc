//! Rendering for orbit-rs: a CPU ray caster of a scene's collision primitives (spheres,
//! capsules, boxes, cylinders, planes) and of the tasks' debug markers, and videos of env
//! steps as animated GIFs (the `--video` flag of `train` and `play`).
//!
//! Frames show one env from the env config's `viewer` camera; they are a view of the physics
//! state, not a photoreal render. Each pixel is independent, so frames are the same for the
//! same state whatever the thread count.

mod camera;
mod error;
mod image;
pub mod intersect;
mod recorder;
mod renderer;
mod video;

pub use camera::Camera;
pub use error::RenderError;
pub use image::Image;
pub use recorder::{VideoCfg, VideoProgress, VideoRecorder, video_path};
pub use renderer::Renderer;
pub use video::{GifThread, GifWriter};
