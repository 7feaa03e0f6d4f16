//! The input stream: on request (`HostToDevice::StreamInput`), the input the model got for
//! every sample goes to the host as `DeviceToHost::Input` frames, one per run of
//! consecutive sample indices in a block, after the block's telemetry and alerts.
//!
//! The pipeline reports each sample's input (`PipelineOutput::Input`) while it runs; they
//! are only copied here then, and encoded after the pipeline returns, so the frame's
//! scratch bytes never add to the pipeline's own stack depth.

use supine_core::pipeline::BLOCK_LEN;
use supine_core::protocol::input_frame;

use crate::link::Link;
use crate::tx_ring::TxRing;

/// Whether the stream is on, and the current block's inputs.
pub(crate) struct InputStream {
    enabled: bool,
    counts: [[i16; 3]; BLOCK_LEN],
    len: usize,
}

impl InputStream {
    /// Off, as at boot.
    pub(crate) const fn new() -> Self {
        Self {
            enabled: false,
            counts: [[0; 3]; BLOCK_LEN],
            len: 0,
        }
    }

    pub(crate) fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
        self.len = 0;
    }

    /// Keeps one sample's input (the block's next), if the stream is on.
    #[inline(always)]
    pub(crate) fn keep(&mut self, counts: [i16; 3]) {
        if self.enabled
            && let Some(slot) = self.counts.get_mut(self.len)
        {
            *slot = counts;
            self.len += 1;
        }
    }

    /// Sends the kept inputs of the block whose sample indices are `indices` (in the order
    /// kept), one frame per run of consecutive indices, numbered from `seq` on.
    // Out of line: once per block, off the per-sample path.
    #[inline(never)]
    pub(crate) fn send(
        &mut self,
        indices: &[u32],
        tx: &mut TxRing,
        link: &mut impl Link,
        seq: &mut u32,
    ) {
        let len = core::mem::take(&mut self.len).min(indices.len());
        let mut start = 0;
        while start < len {
            let first = indices.get(start).copied().unwrap_or(0);
            let mut end = start + 1;
            while end < len && indices.get(end) == Some(&first.wrapping_add((end - start) as u32)) {
                end += 1;
            }
            let mut frame = [0u8; input_frame::MAX_FRAME];
            let counts = self.counts.get(start..end).unwrap_or(&[]);
            let n = input_frame::encode(*seq, first, counts, &mut frame);
            *seq = seq.wrapping_add(1);
            tx.push(frame.get(..n).unwrap_or(&[]), link);
            start = end;
        }
    }
}
