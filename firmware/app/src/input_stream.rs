//! The input stream: on request (`HostToDevice::StreamInput`), the input the model got for
//! every sample goes to the host as `DeviceToHost::Input` frames, one per run of
//! consecutive sample indices in a block, after the block's telemetry and alerts.
//!
//! The pipeline keeps the last block's inputs (`PipelineState::recent_inputs`); they are
//! read and encoded after it returns, so the stream costs nothing per sample when off and
//! its frame's scratch bytes never add to the pipeline's own stack depth.

use supine_core::pipeline::{BLOCK_LEN, PipelineState};
use supine_core::protocol::input_frame;

use crate::link::Link;
use crate::tx_ring::TxRing;

/// Whether the stream is on.
pub(crate) struct InputStream {
    enabled: bool,
}

impl InputStream {
    /// Off, as at boot.
    pub(crate) const fn new() -> Self {
        Self { enabled: false }
    }

    pub(crate) fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// If the stream is on, sends the inputs of the samples just processed, whose indices
    /// are `indices` (at most a block), one frame per run of consecutive indices,
    /// numbered from `seq` on.
    // Out of line: once per block, off the per-sample path.
    #[inline(never)]
    pub(crate) fn send(
        &self,
        indices: &[u32],
        state: &PipelineState,
        tx: &mut TxRing,
        link: &mut impl Link,
        seq: &mut u32,
    ) {
        if !self.enabled {
            return;
        }
        let len = indices.len().min(BLOCK_LEN);
        let mut counts = [[0i16; 3]; BLOCK_LEN];
        state.recent_inputs(counts.get_mut(..len).unwrap_or(&mut []));
        let mut start = 0;
        while start < len {
            let first = indices.get(start).copied().unwrap_or(0);
            let mut end = start + 1;
            while end < len && indices.get(end) == Some(&first.wrapping_add((end - start) as u32)) {
                end += 1;
            }
            let mut buf = [0u8; input_frame::MAX_FRAME];
            let run = counts.get(start..end).unwrap_or(&[]);
            let frame = input_frame::encode(*seq, first, run, &mut buf);
            *seq = seq.wrapping_add(1);
            tx.push(buf.get(frame).unwrap_or(&[]), link);
            start = end;
        }
    }
}
