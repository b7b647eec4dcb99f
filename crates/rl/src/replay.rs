//! The experience replay buffer.

use crate::rng::SplitMix64;

/// A fixed-capacity ring buffer of transitions `(s, a, r, s', done)` with uniform sampling.
///
/// Storage is flat (`capacity * state_dim` floats per state array), allocated once; once
/// full, each push overwrites the oldest transition.
#[derive(Debug, Clone)]
pub(crate) struct ReplayBuffer {
    state_dim: usize,
    capacity: usize,
    len: usize,
    next: usize,
    states: Vec<f32>,
    next_states: Vec<f32>,
    actions: Vec<u32>,
    rewards: Vec<f32>,
    dones: Vec<bool>,
}

/// A sampled mini-batch, row-major, reused between updates to avoid allocating.
#[derive(Debug, Clone, Default)]
pub(crate) struct Batch {
    pub(crate) states: Vec<f32>,
    pub(crate) next_states: Vec<f32>,
    pub(crate) actions: Vec<i64>,
    pub(crate) rewards: Vec<f32>,
    pub(crate) dones: Vec<bool>,
}

impl ReplayBuffer {
    /// An empty buffer; `capacity > 0` is checked by the config.
    pub(crate) fn new(state_dim: usize, capacity: usize) -> Self {
        Self {
            state_dim,
            capacity,
            len: 0,
            next: 0,
            states: vec![0.0; capacity * state_dim],
            next_states: vec![0.0; capacity * state_dim],
            actions: vec![0; capacity],
            rewards: vec![0.0; capacity],
            dones: vec![false; capacity],
        }
    }

    /// Number of transitions held.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Store one transition; both states must have `state_dim` values (checked by the caller).
    pub(crate) fn push(&mut self, state: &[f32], action: usize, reward: f32, next_state: &[f32], done: bool) {
        let d = self.state_dim;
        let i = self.next;
        self.states[i * d..(i + 1) * d].copy_from_slice(state);
        self.next_states[i * d..(i + 1) * d].copy_from_slice(next_state);
        // Action counts come from `Environment::num_actions`, far below u32::MAX in practice;
        // the agent refuses larger ones when it is built.
        self.actions[i] = action as u32;
        self.rewards[i] = reward;
        self.dones[i] = done;
        self.next = (i + 1) % self.capacity;
        self.len = (self.len + 1).min(self.capacity);
    }

    /// Fill `batch` with `size` transitions drawn uniformly, with replacement.
    pub(crate) fn sample(&self, size: usize, rng: &mut SplitMix64, batch: &mut Batch) {
        let d = self.state_dim;
        batch.states.clear();
        batch.next_states.clear();
        batch.actions.clear();
        batch.rewards.clear();
        batch.dones.clear();
        for _ in 0..size {
            let i = rng.below(self.len);
            batch.states.extend_from_slice(&self.states[i * d..(i + 1) * d]);
            batch.next_states.extend_from_slice(&self.next_states[i * d..(i + 1) * d]);
            batch.actions.push(i64::from(self.actions[i]));
            batch.rewards.push(self.rewards[i]);
            batch.dones.push(self.dones[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_overwrites_oldest_and_samples_only_held_transitions() {
        let mut buf = ReplayBuffer::new(2, 3);
        for k in 0..5u8 {
            let s = [f32::from(k), -f32::from(k)];
            buf.push(&s, usize::from(k), f32::from(k) * 10.0, &s, k % 2 == 0);
        }
        assert_eq!(buf.len(), 3);
        let mut rng = SplitMix64::new(1, 0);
        let mut batch = Batch::default();
        buf.sample(200, &mut rng, &mut batch);
        assert_eq!(batch.states.len(), 400);
        let mut seen = [false; 5];
        for (j, &a) in batch.actions.iter().enumerate() {
            assert!((2..5).contains(&a), "sampled evicted transition {a}");
            assert_eq!(batch.states[2 * j], a as f32, "state/action rows misaligned");
            assert_eq!(batch.rewards[j], a as f32 * 10.0);
            assert_eq!(batch.dones[j], a % 2 == 0);
            seen[a as usize] = true;
        }
        assert!(seen[2] && seen[3] && seen[4], "uniform sampling missed one: {seen:?}");
    }
}
