//! [`SinkThread`]: a [`MotionSink`] fed on a thread of its own, in batches, so that a
//! slow sink beside another (the finished surface's height field beside the simulator)
//! runs on the other core instead of in turn with it, and is handed its motions a batch at
//! a time rather than one by one.

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

use crate::motion::{Motion, MotionSink};

/// What the feeding thread hands over: a motion, a source line, or the end.
enum Item {
    Motion(Motion<'static>),
    Line(u64),
    Finish,
}

/// Where the sink runs: on its thread (the batches go through a bounded channel, the
/// thread answers with the sink or its first error when the channel closes), or, where no
/// thread could be started, here, with its first error kept.
enum Place<S: MotionSink> {
    /// The worker answers `None` only where it never received the sink.
    Thread {
        tx: SyncSender<Vec<Item>>,
        worker: JoinHandle<Option<Result<S, S::Error>>>,
    },
    Here {
        sink: S,
        error: Option<S::Error>,
    },
}

/// A [`MotionSink`] that copies every motion and source line into a batch and hands each
/// full batch to `sink` on a thread of its own (at most `depth` batches waiting; the
/// feeding thread waits beyond). The sink sees the same calls in the same order as it
/// would fed directly, so it ends in the same state; [`join`](Self::join) returns it.
///
/// The sink's first error stops it: the motions after it are dropped, and `join` returns
/// that error (a call here never fails: the error is known only once the thread reaches
/// it). A sink that panics makes `join` panic. Where no thread can be started the sink
/// is fed here, one call at a time, with the same outcome.
pub struct SinkThread<S: MotionSink> {
    batch: Vec<Item>,
    size: usize,
    place: Option<Place<S>>,
}

impl<S> SinkThread<S>
where
    S: MotionSink + Send + 'static,
    S::Error: Send + 'static,
{
    /// `sink` on a thread of its own, fed in batches of `size` calls (at least 1), at
    /// most `depth` of them waiting.
    pub fn spawn(sink: S, size: usize, depth: usize) -> Self {
        let (tx, rx) = sync_channel::<Vec<Item>>(depth);
        // The thread receives the sink once it runs, so that a thread that cannot start
        // leaves it here.
        let (give, take) = sync_channel::<S>(1);
        let started = std::thread::Builder::new()
            .name("s2g-sink".into())
            .spawn(move || take.recv().ok().map(|sink| drain(sink, &rx)));
        let place = match started {
            Ok(worker) => match give.send(sink) {
                Ok(()) => Place::Thread { tx, worker },
                Err(back) => Place::Here { sink: back.0, error: None },
            },
            Err(_) => Place::Here { sink, error: None },
        };
        Self { batch: Vec::with_capacity(size.max(1)), size: size.max(1), place: Some(place) }
    }

    /// `sink` fed here, one call at a time (no thread): the baseline the threaded sink is
    /// compared with, which ends in the same state.
    pub fn here(sink: S) -> Self {
        Self { batch: Vec::new(), size: 1, place: Some(Place::Here { sink, error: None }) }
    }

    /// Hands over what is batched, waits for the sink to take every call, and returns it,
    /// or its first error.
    pub fn join(mut self) -> Result<S, S::Error> {
        self.send();
        match self.place.take() {
            Some(Place::Thread { tx, worker }) => {
                drop(tx);
                match worker.join().unwrap_or_else(|p| std::panic::resume_unwind(p)) {
                    Some(done) => done,
                    None => unreachable_sink(),
                }
            }
            Some(Place::Here { sink, error: None }) => Ok(sink),
            Some(Place::Here { error: Some(e), .. }) => Err(e),
            None => unreachable_sink(),
        }
    }

    fn push(&mut self, item: Item) {
        match &mut self.place {
            Some(Place::Here { sink, error }) => {
                if error.is_none()
                    && let Err(e) = feed(sink, &item)
                {
                    *error = Some(e);
                }
            }
            Some(Place::Thread { .. }) => {
                self.batch.push(item);
                if self.batch.len() >= self.size {
                    self.send();
                }
            }
            None => {}
        }
    }

    /// Hands the batch to the thread. A thread gone (its sink failed) drops it: `join`
    /// returns the error.
    fn send(&mut self) {
        if self.batch.is_empty() {
            return;
        }
        let batch = std::mem::replace(&mut self.batch, Vec::with_capacity(self.size));
        if let Some(Place::Thread { tx, .. }) = &self.place {
            let _ = tx.send(batch);
        }
    }
}

/// Stands for a state no call sequence reaches: the sink travels with the place until
/// joined, and a started thread is always sent it.
fn unreachable_sink() -> ! {
    unreachable!("a sink thread always holds its sink until joined")
}

/// Feeds `sink` one item.
fn feed<S: MotionSink>(sink: &mut S, item: &Item) -> Result<(), S::Error> {
    match item {
        Item::Motion(m) => sink.motion(m),
        Item::Line(l) => sink.source_line(*l),
        Item::Finish => sink.finish(),
    }
}

/// The thread's work: every batch until the channel closes, stopping at the first error.
fn drain<S: MotionSink>(mut sink: S, rx: &Receiver<Vec<Item>>) -> Result<S, S::Error> {
    for batch in rx {
        for item in &batch {
            feed(&mut sink, item)?;
        }
    }
    Ok(sink)
}

impl<S> MotionSink for SinkThread<S>
where
    S: MotionSink + Send + 'static,
    S::Error: Send + 'static,
{
    type Error = std::convert::Infallible;

    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error> {
        self.push(Item::Motion(motion.clone().into_owned()));
        Ok(())
    }

    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.push(Item::Line(line));
        Ok(())
    }

    /// Hands the sink its `finish` after every call before it (on its thread: this does
    /// not wait for it; [`SinkThread::join`] does).
    fn finish(&mut self) -> Result<(), Self::Error> {
        self.push(Item::Finish);
        self.send();
        Ok(())
    }
}

impl<S: MotionSink> Drop for SinkThread<S> {
    /// A sink thread dropped unjoined (its feeder failed) is told to stop and waited for,
    /// its outcome dropped.
    fn drop(&mut self) {
        if let Some(Place::Thread { tx, worker }) = self.place.take() {
            drop(tx);
            let _ = worker.join();
        }
    }
}
