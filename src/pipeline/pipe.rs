//! The writer-to-parser pipe: a bounded channel of text chunks between the planner's thread
//! and the parser, so no setup's program is ever held whole.

use std::io::{BufRead, Read, Write};
use std::time::Instant;

/// Bytes per chunk of [`chunk_channel`], and chunks in flight.
pub(super) const CHUNK_BYTES: usize = 1 << 18;
pub(super) const CHUNKS_IN_FLIGHT: usize = 8;

/// A bounded byte stream from a writer on one thread to a [`BufRead`] on another, in
/// chunks of [`CHUNK_BYTES`], at most [`CHUNKS_IN_FLIGHT`] of them waiting: memory stays
/// bounded whatever the program's size. With `keep`, the writer also keeps every byte
/// and [`ChunkWriter::finish`] returns them.
pub(super) fn chunk_channel<'a>(keep: bool) -> (ChunkWriter, ChunkReader<'a>) {
    let (tx, rx) = std::sync::mpsc::sync_channel(CHUNKS_IN_FLIGHT);
    let writer = ChunkWriter {
        buf: Vec::with_capacity(CHUNK_BYTES),
        tx,
        kept: keep.then(Vec::new),
        copy: None,
        blocked: std::time::Duration::ZERO,
    };
    let reader = ChunkReader {
        rx,
        chunk: Vec::new(),
        pos: 0,
        waited: std::time::Duration::ZERO,
        deadline: None,
        checkpoint: None,
    };
    (writer, reader)
}

/// The writing end of [`chunk_channel`]. A write fails once the reader has hung up.
pub(super) struct ChunkWriter {
    pub(super) buf: Vec<u8>,
    pub(super) tx: std::sync::mpsc::SyncSender<Vec<u8>>,
    pub(super) kept: Option<Vec<u8>>,
    /// Where every byte is also written.
    pub(super) copy: Option<Box<dyn std::io::Write + Send>>,
    /// Time spent waiting for the reader.
    pub(super) blocked: std::time::Duration,
}

impl ChunkWriter {
    pub(super) fn send(&mut self) -> std::io::Result<()> {
        if self.buf.is_empty() {
            return Ok(());
        }
        let chunk = std::mem::replace(&mut self.buf, Vec::with_capacity(CHUNK_BYTES));
        if let Some(kept) = &mut self.kept {
            kept.extend_from_slice(&chunk);
        }
        if let Some(copy) = &mut self.copy {
            copy.write_all(&chunk)?;
        }
        let t = Instant::now();
        let sent = self.tx.send(chunk);
        self.blocked += t.elapsed();
        sent.map_err(|_| std::io::Error::new(std::io::ErrorKind::BrokenPipe, "the program's reader stopped"))
    }

    /// Sends what is buffered, then a checkpoint: the reader, once it has returned every
    /// byte before it, calls its [`ChunkReader::checkpoint`].
    pub(super) fn checkpoint(&mut self) -> std::io::Result<()> {
        self.send()?;
        let t = Instant::now();
        let sent = self.tx.send(Vec::new());
        self.blocked += t.elapsed();
        sent.map_err(|_| std::io::Error::new(std::io::ErrorKind::BrokenPipe, "the program's reader stopped"))
    }

    /// Sends what is buffered and closes the stream; returns the kept bytes (empty
    /// without `keep`) and the time spent waiting for the reader.
    pub(super) fn finish(mut self) -> std::io::Result<(Vec<u8>, std::time::Duration)> {
        self.send()?;
        if let Some(copy) = &mut self.copy {
            copy.flush()?;
        }
        Ok((self.kept.take().unwrap_or_default(), self.blocked))
    }
}

impl std::io::Write for ChunkWriter {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.buf.extend_from_slice(bytes);
        if self.buf.len() >= CHUNK_BYTES {
            self.send()?;
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.send()
    }
}

/// The reading end of [`chunk_channel`]: ends when the writer is dropped.
pub(super) struct ChunkReader<'a> {
    pub(super) rx: std::sync::mpsc::Receiver<Vec<u8>>,
    pub(super) chunk: Vec<u8>,
    pub(super) pos: usize,
    /// Time spent waiting for the writer.
    pub(super) waited: std::time::Duration,
    /// Reading fails with [`std::io::ErrorKind::TimedOut`] from this time on.
    pub(super) deadline: Option<Instant>,
    /// Called at each [`ChunkWriter::checkpoint`], every byte before it read (its time
    /// counts as waiting).
    pub(super) checkpoint: Option<Box<dyn FnMut() + 'a>>,
}

impl Read for ChunkReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        read_from_buffer(self, buf)
    }
}

impl BufRead for ChunkReader<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        while self.pos == self.chunk.len() {
            let t = Instant::now();
            let next = match self.deadline {
                Some(at) => loop {
                    if Instant::now() >= at {
                        return Err(std::io::Error::new(
                            std::io::ErrorKind::TimedOut,
                            "the time limit passed",
                        ));
                    }
                    match self.rx.recv_timeout(std::time::Duration::from_millis(100)) {
                        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                        Ok(chunk) => break Ok(chunk),
                        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break Err(()),
                    }
                },
                None => self.rx.recv().map_err(|_| ()),
            };
            match next {
                // Sent empty, a chunk is a checkpoint: every byte before it has been read.
                Ok(chunk) if chunk.is_empty() => {
                    if let Some(at_checkpoint) = &mut self.checkpoint {
                        at_checkpoint();
                    }
                }
                Ok(chunk) => (self.chunk, self.pos) = (chunk, 0),
                // The writer is gone: the end of the program.
                Err(()) => {
                    self.waited += t.elapsed();
                    return Ok(&[]);
                }
            }
            self.waited += t.elapsed();
        }
        Ok(&self.chunk[self.pos..])
    }

    fn consume(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.chunk.len());
    }
}
/// [`Read::read`] of a source that is a [`BufRead`] at heart.
pub(super) fn read_from_buffer(source: &mut impl BufRead, buf: &mut [u8]) -> std::io::Result<usize> {
    let avail = source.fill_buf()?;
    let n = avail.len().min(buf.len());
    buf[..n].copy_from_slice(&avail[..n]);
    source.consume(n);
    Ok(n)
}

#[cfg(test)]
mod tests {
    use std::io::{BufRead, Read, Write};

    use super::{CHUNK_BYTES, CHUNKS_IN_FLIGHT, chunk_channel};

    /// Bytes written on one thread arrive in order on the other, across many chunks, and
    /// the kept copy is the same bytes.
    #[test]
    fn a_chunk_channel_delivers_every_byte_in_order() {
        let data: Vec<u8> = (0..3 * CHUNK_BYTES + 12_345).map(|i| (i * 7 % 251) as u8).collect();
        let (mut w, mut r) = chunk_channel(true);
        let (kept, read) = std::thread::scope(|s| {
            let writer = s.spawn(|| {
                for piece in data.chunks(1000) {
                    w.write_all(piece).unwrap();
                }
                w.finish().unwrap().0
            });
            let mut read = Vec::new();
            r.read_to_end(&mut read).unwrap();
            (writer.join().unwrap(), read)
        });
        assert_eq!(read.len(), data.len());
        assert!(read == data, "bytes differ");
        assert!(kept == data, "kept bytes differ");
        assert!(r.fill_buf().unwrap().is_empty(), "the stream ended");
    }

    /// Without `keep` nothing is kept; a writer dropped part way ends the stream there.
    #[test]
    fn a_dropped_writer_ends_the_stream() {
        let (mut w, mut r) = chunk_channel(false);
        w.write_all(b"G0 X1\n").unwrap();
        w.flush().unwrap();
        drop(w);
        let mut text = String::new();
        r.read_to_string(&mut text).unwrap();
        assert_eq!(text, "G0 X1\n");
        let (w, _r) = chunk_channel(false);
        assert!(w.finish().unwrap().0.is_empty());
    }

    /// A checkpoint reaches the reader after every byte written before it and before any
    /// written after it, whatever the chunking: its hook sees exactly the bytes before it
    /// read, and the writer may wait there for the hook's answer.
    #[test]
    fn a_checkpoint_comes_after_the_bytes_before_it() {
        let before: Vec<u8> = (0..2 * CHUNK_BYTES + 777).map(|i| (i * 13 % 251) as u8).collect();
        let after = b"after the checkpoint".to_vec();
        let (mut w, mut r) = chunk_channel(true);
        let (answer_tx, answer_rx) = std::sync::mpsc::channel();
        let read = std::rc::Rc::new(std::cell::Cell::new(0usize));
        let (seen, count) = (std::rc::Rc::new(std::cell::Cell::new(None)), read.clone());
        let seen_in_hook = seen.clone();
        r.checkpoint = Some(Box::new(move || {
            seen_in_hook.set(Some(count.get()));
            answer_tx.send(count.get()).unwrap();
        }));
        let (answer, kept, text) = std::thread::scope(|s| {
            let (first, then) = (&before, &after);
            let writer = s.spawn(move || {
                w.write_all(first).unwrap();
                w.checkpoint().unwrap();
                let answer = answer_rx.recv().unwrap();
                w.write_all(then).unwrap();
                (answer, w.finish().unwrap().0)
            });
            let mut text = Vec::new();
            let mut piece = [0u8; 1000];
            loop {
                let n = r.read(&mut piece).unwrap();
                if n == 0 {
                    break;
                }
                text.extend_from_slice(&piece[..n]);
                read.set(text.len());
            }
            let (answer, kept) = writer.join().unwrap();
            (answer, kept, text)
        });
        assert_eq!(seen.get(), Some(before.len()), "the hook ran once every byte before it was read");
        assert_eq!(answer, before.len());
        assert!(text == [before.as_slice(), after.as_slice()].concat(), "bytes differ");
        assert!(kept == text, "the kept copy holds no checkpoint");
    }

    /// A reader that hangs up makes the writer fail instead of blocking for ever.
    #[test]
    fn a_writer_fails_once_the_reader_hangs_up() {
        let (mut w, r) = chunk_channel(false);
        drop(r);
        let piece = vec![b'x'; CHUNK_BYTES];
        let failed = (0..=CHUNKS_IN_FLIGHT).find_map(|_| w.write_all(&piece).err());
        let e = failed.expect("writing into a closed stream failed");
        assert_eq!(e.kind(), std::io::ErrorKind::BrokenPipe);
    }
}
