//! Small environments whose optimal policies are known in closed form.

use s2g_rl::{Environment, Step};

/// The error of the test environments (only [`Broken::EnvError`] returns it).
#[derive(Debug, thiserror::Error)]
#[error("test environment failure")]
pub struct EnvFailure;

/// A one-hot vector of length `n` with a 1 at `i`.
pub fn one_hot(i: usize, n: usize) -> Vec<f32> {
    let mut v = vec![0.0; n];
    v[i] = 1.0;
    v
}

/// A 1-D corridor of `n` cells; the goal is the rightmost one. Action 0 moves left
/// (clamped at cell 0), action 1 moves right. Each step costs `STEP_COST`; entering the goal
/// pays `GOAL_REWARD` and ends the episode. Episodes start in a non-goal cell chosen by the
/// reset seed. The optimal policy always moves right and reaches the goal from cell `s` in
/// `n - 1 - s` steps.
#[derive(Debug, Clone)]
pub struct Corridor {
    pub n: usize,
    pub pos: usize,
    /// Start cell forced by the test instead of drawn from the seed.
    pub fixed_start: Option<usize>,
}

impl Corridor {
    pub const STEP_COST: f32 = -0.05;
    pub const GOAL_REWARD: f32 = 1.0;

    pub fn new(n: usize) -> Self {
        Self { n, pos: 0, fixed_start: None }
    }

    /// The undiscounted return of the optimal policy from cell `start`.
    pub fn optimal_return(&self, start: usize) -> f32 {
        let k = self.n - 1 - start;
        Self::GOAL_REWARD + Self::STEP_COST * (k - 1) as f32
    }
}

impl Environment for Corridor {
    type Error = EnvFailure;

    fn state_dim(&self) -> usize {
        self.n
    }

    fn num_actions(&self) -> usize {
        2
    }

    fn reset(&mut self, rng_seed: u64) -> Result<Vec<f32>, EnvFailure> {
        self.pos = self.fixed_start.unwrap_or((rng_seed % (self.n as u64 - 1)) as usize);
        Ok(one_hot(self.pos, self.n))
    }

    fn step(&mut self, action: usize) -> Result<Step, EnvFailure> {
        self.pos = if action == 1 { self.pos + 1 } else { self.pos.saturating_sub(1) };
        let done = self.pos == self.n - 1;
        Ok(Step {
            state: one_hot(self.pos, self.n),
            reward: if done { Self::GOAL_REWARD } else { Self::STEP_COST },
            done,
        })
    }
}

/// A contextual bandit: the state is a one-hot context out of `CONTEXTS`, each episode is one
/// pull, and only the context's best arm pays 1. The best arm differs per context, so a
/// policy must read the state.
#[derive(Debug, Clone, Default)]
pub struct Bandit {
    pub context: usize,
}

impl Bandit {
    pub const CONTEXTS: usize = 4;
    pub const ARMS: usize = 4;

    pub fn best_arm(context: usize) -> usize {
        (3 * context + 1) % Self::ARMS
    }
}

impl Environment for Bandit {
    type Error = EnvFailure;

    fn state_dim(&self) -> usize {
        Self::CONTEXTS
    }

    fn num_actions(&self) -> usize {
        Self::ARMS
    }

    fn reset(&mut self, rng_seed: u64) -> Result<Vec<f32>, EnvFailure> {
        self.context = (rng_seed % Self::CONTEXTS as u64) as usize;
        Ok(one_hot(self.context, Self::CONTEXTS))
    }

    fn step(&mut self, action: usize) -> Result<Step, EnvFailure> {
        let reward = if action == Self::best_arm(self.context) { 1.0 } else { 0.0 };
        Ok(Step { state: one_hot(self.context, Self::CONTEXTS), reward, done: true })
    }
}

/// Ways an environment can break its contract; each must give a typed error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Broken {
    ResetWrongLength,
    StepWrongLength,
    NanState,
    InfiniteState,
    NanReward,
    EnvError,
}

/// A 2-dim, 2-action environment that misbehaves as its [`Broken`] says on the third step.
#[derive(Debug, Clone)]
pub struct BrokenEnv {
    pub kind: Broken,
    pub steps: usize,
}

impl Environment for BrokenEnv {
    type Error = EnvFailure;

    fn state_dim(&self) -> usize {
        2
    }

    fn num_actions(&self) -> usize {
        2
    }

    fn reset(&mut self, _rng_seed: u64) -> Result<Vec<f32>, EnvFailure> {
        self.steps = 0;
        Ok(if self.kind == Broken::ResetWrongLength { vec![0.0; 3] } else { vec![0.0; 2] })
    }

    fn step(&mut self, _action: usize) -> Result<Step, EnvFailure> {
        self.steps += 1;
        let mut step = Step { state: vec![0.5, 0.5], reward: 0.0, done: false };
        if self.steps >= 3 {
            match self.kind {
                Broken::ResetWrongLength => {}
                Broken::StepWrongLength => step.state = vec![0.5],
                Broken::NanState => step.state[1] = f32::NAN,
                Broken::InfiniteState => step.state[0] = f32::INFINITY,
                Broken::NanReward => step.reward = f32::NAN,
                Broken::EnvError => return Err(EnvFailure),
            }
        }
        Ok(step)
    }
}
