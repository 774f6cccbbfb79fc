//! Animated GIF output: pure Rust, readable by every browser and image viewer, no ffmpeg.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{SyncSender, sync_channel};
use std::thread::JoinHandle;

use crate::{Image, RenderError};

/// NeuQuant sampling factor of the per-frame palette (1 best, 30 fastest; 10 is gif's default).
const QUANTIZER_SPEED: i32 = 10;

/// Writes frames of one size into an animated GIF that loops.
pub struct GifWriter {
    encoder: Option<gif::Encoder<BufWriter<File>>>,
    path: PathBuf,
    size: (u16, u16),
    delay_cs: u16,
    frames: usize,
}

impl GifWriter {
    /// Creates `path` (and its directory) for frames of `width × height` shown `frame_s`
    /// seconds each (GIF delays are whole hundredths of a second; at least one).
    pub fn create(path: &Path, width: u32, height: u32, frame_s: f32) -> Result<Self, RenderError> {
        let io = |source| RenderError::Io {
            path: path.to_path_buf(),
            source,
        };
        let gif = |source| RenderError::Gif {
            path: path.to_path_buf(),
            source,
        };
        let size = (
            u16::try_from(width).map_err(|_| too_large(path))?,
            u16::try_from(height).map_err(|_| too_large(path))?,
        );
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        let file = BufWriter::new(File::create(path).map_err(io)?);
        let mut encoder = gif::Encoder::new(file, size.0, size.1, &[]).map_err(gif)?;
        encoder.set_repeat(gif::Repeat::Infinite).map_err(gif)?;
        Ok(Self {
            encoder: Some(encoder),
            path: path.to_path_buf(),
            size,
            delay_cs: (frame_s * 100.0).round().clamp(1.0, f32::from(u16::MAX)) as u16,
            frames: 0,
        })
    }

    /// The file written to.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Appends a frame (its own 256-colour palette); it must have the size given at creation.
    pub fn push(&mut self, image: &Image) -> Result<(), RenderError> {
        if (image.width(), image.height()) != (u32::from(self.size.0), u32::from(self.size.1)) {
            return Err(RenderError::InvalidVideo(format!(
                "frame of {}×{} pushed into a {}×{} video",
                image.width(),
                image.height(),
                self.size.0,
                self.size.1
            )));
        }
        let mut frame =
            gif::Frame::from_rgb_speed(self.size.0, self.size.1, image.rgb(), QUANTIZER_SPEED);
        frame.delay = self.delay_cs;
        let Some(encoder) = self.encoder.as_mut() else {
            return Err(ended_early(&self.path));
        };
        if let Err(source) = encoder.write_frame(&frame) {
            self.discard();
            return Err(RenderError::Gif {
                path: self.path.clone(),
                source,
            });
        }
        self.frames += 1;
        Ok(())
    }

    /// Drops the encoder and removes the unfinished file: a failed video leaves no truncated
    /// GIF that a viewer would show as complete.
    fn discard(&mut self) {
        self.encoder = None;
        if let Err(e) = std::fs::remove_file(&self.path) {
            tracing::warn!(
                "{}: removing the unfinished video: {e}",
                self.path.display()
            );
        }
    }

    /// Writes the trailer and closes the file.
    pub fn finish(mut self) -> Result<PathBuf, RenderError> {
        if self.encoder.is_none() {
            return Err(ended_early(&self.path));
        }
        self.close()?;
        Ok(std::mem::take(&mut self.path))
    }

    fn close(&mut self) -> Result<(), RenderError> {
        let Some(encoder) = self.encoder.take() else {
            return Ok(());
        };
        let path = self.path.clone();
        let written = encoder
            .into_inner()
            .map_err(|source| RenderError::Gif { path, source })
            .and_then(|mut file| {
                std::io::Write::flush(&mut file).map_err(|source| RenderError::Io {
                    path: self.path.clone(),
                    source,
                })
            });
        if written.is_err() {
            self.discard();
        }
        written
    }
}

impl Drop for GifWriter {
    fn drop(&mut self) {
        if let Err(e) = self.close() {
            tracing::warn!("{e}");
        }
    }
}

/// Frames a [`GifThread`] holds before `push` waits for the encoder (about 15 MB at 320×240).
const QUEUE_FRAMES: usize = 64;

/// A [`GifWriter`] on a thread of its own: the palette quantisation (most of a frame's cost)
/// and the writing overlap the simulation; `push` only waits when the queue is full.
pub struct GifThread {
    sender: Option<SyncSender<Image>>,
    handle: Option<JoinHandle<Result<PathBuf, RenderError>>>,
    frames: usize,
}

impl GifThread {
    /// Moves `writer` to a new thread.
    pub fn spawn(mut writer: GifWriter) -> Self {
        let (sender, frames) = sync_channel::<Image>(QUEUE_FRAMES);
        let handle = std::thread::spawn(move || {
            for image in frames {
                writer.push(&image)?;
            }
            writer.finish()
        });
        Self {
            sender: Some(sender),
            handle: Some(handle),
            frames: 0,
        }
    }

    /// Frames queued so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Queues a frame; a failure of the encoder (e.g. a full disk) is returned here, once: the
    /// video has then ended and later calls return an error without a file.
    pub fn push(&mut self, image: Image) -> Result<(), RenderError> {
        let Some(sender) = self.sender.as_ref() else {
            return Err(self.ended());
        };
        if sender.send(image).is_err() {
            // The encoder stopped early: its result says why.
            self.sender = None;
            return self.join().map(|_| ());
        }
        self.frames += 1;
        Ok(())
    }

    /// Ends the video: no more frames; [`join`](Self::join) waits for the file.
    pub fn close(&mut self) {
        self.sender = None;
    }

    /// Whether the encoder has written the whole file (after [`close`](Self::close)).
    pub fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(|h| h.is_finished())
    }

    /// Closes the video and waits for the encoder: the path written, or what went wrong.
    /// After the first call, an error: the result was returned then.
    pub fn join(&mut self) -> Result<PathBuf, RenderError> {
        self.close();
        let Some(handle) = self.handle.take() else {
            return Err(self.ended());
        };
        handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    }

    fn ended(&self) -> RenderError {
        RenderError::InvalidVideo(format!(
            "the video ended after {} frames; its result was returned then",
            self.frames
        ))
    }
}

fn ended_early(path: &Path) -> RenderError {
    RenderError::InvalidVideo(format!(
        "{}: the video has ended (finished, or stopped by an earlier error)",
        path.display()
    ))
}

impl Drop for GifThread {
    fn drop(&mut self) {
        if self.handle.is_some()
            && let Err(e) = self.join()
        {
            tracing::warn!("{e}");
        }
    }
}

fn too_large(path: &Path) -> RenderError {
    RenderError::InvalidViewer {
        field: "resolution".into(),
        message: format!(
            "{}: GIF frames are at most 65535 pixels each way",
            path.display()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_with_their_size_delay_and_colours() {
        let dir = std::env::temp_dir().join(format!("orbit-render-gif-{}", std::process::id()));
        let path = dir.join("clip.gif");
        let mut w = GifWriter::create(&path, 8, 6, 0.02).unwrap();
        for k in 0..3u8 {
            let mut img = Image::new(8, 6);
            for (i, px) in img.rgb_mut().chunks_exact_mut(3).enumerate() {
                // Left half red, right half blue, brighter each frame.
                let level = 100 + 50 * k;
                px.copy_from_slice(&if i % 8 < 4 {
                    [level, 0, 0]
                } else {
                    [0, 0, level]
                });
            }
            w.push(&img).unwrap();
        }
        assert!(w.push(&Image::new(4, 4)).is_err());
        assert_eq!(w.frames(), 3);
        let written = w.finish().unwrap();
        let mut opts = gif::DecodeOptions::new();
        opts.set_color_output(gif::ColorOutput::RGBA);
        let mut dec = opts.read_info(File::open(&written).unwrap()).unwrap();
        let mut frames = 0;
        while let Some(f) = dec.read_next_frame().unwrap() {
            assert_eq!((f.width, f.height, f.delay), (8, 6, 2));
            let level = 100 + 50 * frames;
            // NeuQuant palettes are close, not exact: within 8 levels.
            let left = &f.buffer[0..3];
            let right = &f.buffer[4 * 7..4 * 7 + 3];
            assert!(
                (i32::from(left[0]) - level).abs() <= 8 && left[2] <= 8,
                "{left:?}"
            );
            assert!(
                (i32::from(right[2]) - level).abs() <= 8 && right[0] <= 8,
                "{right:?}"
            );
            frames += 1;
        }
        assert_eq!(frames, 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A full disk (a link to Linux's `/dev/full`, whose writes fail with ENOSPC) ends the
    /// video with an error, not a panic, and leaves no file behind; later calls are errors too.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_disk_is_an_error_and_leaves_no_file() {
        let dir = std::env::temp_dir().join(format!("orbit-render-full-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("clip.gif");
        std::os::unix::fs::symlink("/dev/full", &path).unwrap();
        let writer = GifWriter::create(&path, 64, 64, 0.02).unwrap();
        let mut video = GifThread::spawn(writer);
        let mut image = Image::new(64, 64);
        let mut failed = None;
        // Each noisy 64×64 frame is several kB: the 8 kB buffer flushes within a few frames.
        for k in 0..QUEUE_FRAMES * 4 {
            for (i, px) in image.rgb_mut().iter_mut().enumerate() {
                *px = ((i * 7919 + k * 104_729) % 251) as u8;
            }
            if let Err(e) = video.push(image.clone()) {
                failed = Some(e);
                break;
            }
        }
        let error = match failed {
            Some(e) => e,
            None => video.join().unwrap_err(),
        };
        assert!(error.to_string().contains("No space left"), "{error}");
        assert!(video.push(image).is_err());
        assert!(video.join().is_err());
        assert!(
            std::fs::symlink_metadata(&path).is_err(),
            "the file was left"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
