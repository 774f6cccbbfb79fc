//! Videos of env steps (Isaac Lab's `--video`, gymnasium's `RecordVideo`): every `interval`
//! env steps, the next `length` steps of one env are rendered into an animated GIF.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use orbit_managers::{EnvError, ManagerBasedRlEnv, StepObserver};

use crate::{GifThread, GifWriter, Image, RenderError, Renderer};

/// When and where videos are recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct VideoCfg {
    /// Directory of the GIF files (`rl-video-step-<step>.gif`).
    pub dir: PathBuf,
    /// Env steps per video.
    pub length: usize,
    /// A video starts at every multiple of this many env steps (`None`: only at the first).
    pub interval: Option<u64>,
}

/// Records videos of an env as a [`StepObserver`] (install it with
/// [`ManagerBasedRlEnv::set_step_observer`]).
pub struct VideoRecorder {
    cfg: VideoCfg,
    renderer: Renderer,
    image: Image,
    frame_s: f32,
    /// Env steps seen so far.
    step: u64,
    /// The video being recorded.
    current: Option<GifThread>,
    /// Videos complete but still being encoded.
    closing: Vec<GifThread>,
    progress: VideoProgress,
}

/// A handle on a recorder's frame count that stays valid after the recorder is installed in
/// an env (e.g. for `play` to keep stepping until its video is complete).
#[derive(Clone, Debug, Default)]
pub struct VideoProgress(Arc<AtomicU64>);

impl VideoProgress {
    /// Frames rendered so far, all videos together.
    pub fn frames(&self) -> u64 {
        self.0.load(Ordering::Relaxed)
    }
}

impl VideoRecorder {
    /// A recorder of `env`'s viewer camera (its config's `viewer`).
    pub fn new(env: &ManagerBasedRlEnv, cfg: VideoCfg) -> Result<Self, RenderError> {
        if cfg.length == 0 || cfg.interval == Some(0) {
            return Err(RenderError::InvalidVideo(format!(
                "expected a positive video length and interval, got {} and {:?}",
                cfg.length, cfg.interval
            )));
        }
        let scene = env.scene();
        let renderer = Renderer::new(&scene.desc, &env.cfg.base.viewer, env.num_envs())?;
        Ok(Self {
            image: renderer.new_image(),
            renderer,
            frame_s: env.step_dt(),
            step: 0,
            current: None,
            closing: Vec::new(),
            progress: VideoProgress::default(),
            cfg,
        })
    }

    /// A handle on the number of frames rendered.
    pub fn progress(&self) -> VideoProgress {
        self.progress.clone()
    }

    /// Collects the videos whose encoders are done (all of them with `wait`).
    fn collect_closed(&mut self, wait: bool) -> Result<(), RenderError> {
        let mut k = 0;
        while k < self.closing.len() {
            if wait || self.closing[k].is_finished() {
                let path = self.closing.swap_remove(k).join()?;
                tracing::info!("wrote {}", path.display());
            } else {
                k += 1;
            }
        }
        Ok(())
    }

    /// Renders the env's current state into the open video, opening one when a video is due.
    fn record(&mut self, env: &ManagerBasedRlEnv) -> Result<(), RenderError> {
        let due = match self.cfg.interval {
            Some(every) => self.step.is_multiple_of(every),
            None => self.step == 0,
        };
        self.collect_closed(false)?;
        if self.current.is_none() && due {
            let path = video_path(&self.cfg.dir, self.step);
            let (w, h) = (self.image.width(), self.image.height());
            let writer = GifWriter::create(&path, w, h, self.frame_s)?;
            self.current = Some(GifThread::spawn(writer));
        }
        self.step += 1;
        let Some(video) = self.current.as_mut() else {
            return Ok(());
        };
        let markers = env.debug_markers(self.renderer.env());
        self.renderer
            .render(env.scene().backend.as_ref(), &markers, &mut self.image);
        if let Err(e) = video.push(self.image.clone()) {
            // The encoder has stopped and removed its file: nothing is left to finish.
            self.current = None;
            return Err(e);
        }
        self.progress.0.fetch_add(1, Ordering::Relaxed);
        if video.frames() >= self.cfg.length {
            let mut done = self.current.take().expect("open");
            done.close();
            self.closing.push(done);
        }
        Ok(())
    }
}

impl Drop for VideoRecorder {
    /// Ends an unfinished video and waits for every encoder, so that the files are complete.
    fn drop(&mut self) {
        if let Some(mut video) = self.current.take() {
            video.close();
            self.closing.push(video);
        }
        if let Err(e) = self.collect_closed(true) {
            tracing::warn!("{e}");
        }
    }
}

impl StepObserver for VideoRecorder {
    fn after_step(&mut self, env: &ManagerBasedRlEnv) -> Result<(), EnvError> {
        self.record(env)
            .map_err(|e| EnvError::Observer(e.to_string()))
    }
}

/// `dir/rl-video-step-<step>.gif` (gymnasium's file names).
pub fn video_path(dir: &Path, step: u64) -> PathBuf {
    dir.join(format!("rl-video-step-{step}.gif"))
}
