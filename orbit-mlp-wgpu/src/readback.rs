//! Reading results back: waiting for a submission and copying a mapped buffer's floats out.

use std::sync::mpsc;

use crate::MlpError;

/// Waits for `submission`, maps the first `bytes` of `staging` (a `MAP_READ` buffer the
/// submission copied into), hands its floats to `take` and unmaps it. `what` names the results
/// in errors.
pub(crate) fn read_mapped<T>(
    device: &wgpu::Device,
    submission: wgpu::SubmissionIndex,
    (staging, bytes): (&wgpu::Buffer, u64),
    what: &str,
    take: impl FnOnce(&[f32]) -> T,
) -> Result<T, MlpError> {
    let slice = staging.slice(..bytes);
    let (sender, receiver) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = sender.send(r);
    });
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        })
        .map_err(|e| MlpError::Device(format!("waiting for the {what}: {e}")))?;
    receiver
        .recv()
        .map_err(|e| MlpError::Device(format!("the readback was dropped: {e}")))?
        .map_err(|e| MlpError::Device(format!("reading the {what} back: {e}")))?;
    let taken = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| MlpError::Device(format!("reading the {what} back: {e}")))?;
        take(bytemuck::cast_slice(&view))
    };
    staging.unmap();
    Ok(taken)
}
