//! The `.rrd` file sink: Rerun's own encoder writing into our file on the batcher's thread.
//!
//! Rerun's `FileSink` writes on a thread of its own and, when a write fails (a full disk, a
//! file-size limit), only logs the cause and ends the thread: the caller sees "File-writer
//! thread shut down prematurely". This sink keeps the first I/O error and hands it back from
//! [`RrdWriter::finish`], so the message names the real cause. The bytes are the same: the
//! same encoder, options (compressed protobuf) and footer as `FileSink`.

use std::io::{BufWriter, Write as _};
use std::path::Path;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rerun::external::re_log_encoding::{CrateVersion, Encoder, EncodingOptions};
use rerun::log::LogMsg;
use rerun::sink::{LogSink, SinkFlushError};

type FileEncoder = Encoder<BufWriter<std::fs::File>>;

#[derive(Default)]
struct State {
    encoder: Option<FileEncoder>,
    /// The first failure; later messages are dropped.
    error: Option<String>,
}

fn lock(state: &Mutex<State>) -> MutexGuard<'_, State> {
    // A poisoned lock only means a panic elsewhere; the state itself stays consistent.
    state
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The sink half, owned by the recording stream.
pub struct RrdSink(Arc<Mutex<State>>);

/// Our half: finishes the file after the stream is dropped and reports what went wrong.
pub struct RrdWriter(Arc<Mutex<State>>);

/// Creates (truncates) `path` and writes the stream header; returns the sink for the
/// recording stream and the writer that finishes the file.
pub fn create(path: &Path) -> std::io::Result<(RrdSink, RrdWriter)> {
    let file = std::fs::File::create(path)?;
    let encoder = Encoder::new_eager(
        CrateVersion::LOCAL,
        EncodingOptions::PROTOBUF_COMPRESSED,
        BufWriter::new(file),
    )
    .map_err(std::io::Error::other)?;
    let state = Arc::new(Mutex::new(State {
        encoder: Some(encoder),
        error: None,
    }));
    Ok((RrdSink(state.clone()), RrdWriter(state)))
}

impl State {
    fn fail(&mut self, e: &dyn std::fmt::Display) {
        if self.error.is_none() {
            let text = e.to_string();
            // The encoder says "Failed to write: <io error>"; the io error is the message.
            let text = text.strip_prefix("Failed to write: ").unwrap_or(&text);
            self.error = Some(text.to_owned());
        }
        // Nothing more is written after a failure.
        if let Some(mut enc) = self.encoder.take() {
            enc.do_not_emit_footer();
            let _ = enc.into_inner();
        }
    }
}

impl LogSink for RrdSink {
    fn send(&self, msg: LogMsg) {
        let mut state = lock(&self.0);
        if let Some(enc) = state.encoder.as_mut()
            && let Err(e) = enc.append(&msg)
        {
            state.fail(&e);
        }
    }

    fn flush_blocking(&self, _timeout: Duration) -> Result<(), SinkFlushError> {
        let mut state = lock(&self.0);
        if let Some(enc) = state.encoder.as_mut()
            && let Err(e) = enc.flush_blocking()
        {
            state.fail(&e);
        }
        match &state.error {
            Some(e) => Err(SinkFlushError::failed(e.clone())),
            None => Ok(()),
        }
    }

    fn defers_finalization_to_shutdown(&self) -> bool {
        true
    }
}

impl RrdWriter {
    /// The first write error so far, if any.
    pub fn failed(&self) -> Option<String> {
        lock(&self.0).error.clone()
    }

    /// Writes the footer and flushes the file; the first error of the whole recording, if
    /// any, as text.
    pub fn finish(self) -> Result<(), String> {
        let mut state = lock(&self.0);
        if let Some(mut enc) = state.encoder.take() {
            let written = enc
                .finish()
                .map_err(|e| e.to_string())
                .and_then(|()| enc.into_inner().map_err(|e| e.to_string()))
                .and_then(|mut w| w.flush().map_err(|e| e.to_string()));
            if let Err(e) = written {
                state.fail(&e);
            }
        }
        match state.error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}
