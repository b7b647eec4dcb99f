//! [`StrategyRegistry`]: clearing strategies by name, for the policy and the CLI.

use std::sync::Arc;

use crate::strategy::ClearingStrategy;

/// A name that no strategy of a [`StrategyRegistry`] has.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown clearing strategy {name:?} (known: {})", known.join(", "))]
pub struct UnknownStrategy {
    /// The name asked for.
    pub name: String,
    /// The registry's names, in its order.
    pub known: Vec<String>,
}

/// Clearing strategies by name ([`ClearingStrategy::name`]), in registration order.
///
/// The built-in registry, [`strategies()`](crate::strategies), holds `zigzag` (along X),
/// `periphery` and `spiral`, in that order. A caller with a strategy of its own clones it
/// and [`register`](Self::register)s the new one (see the crate docs for an example).
#[derive(Debug, Clone, Default)]
pub struct StrategyRegistry {
    entries: Vec<Arc<dyn ClearingStrategy>>,
}

impl StrategyRegistry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }

    /// A registry of `strategies`, registered in order.
    pub fn from_strategies(strategies: impl IntoIterator<Item = Arc<dyn ClearingStrategy>>) -> Self {
        let mut registry = Self::new();
        for s in strategies {
            registry.register(s);
        }
        registry
    }

    /// Adds `strategy` under its name, after the others; a strategy already registered
    /// under that name (compared without regard to ASCII case) is replaced in its place and
    /// returned.
    pub fn register(&mut self, strategy: Arc<dyn ClearingStrategy>) -> Option<Arc<dyn ClearingStrategy>> {
        match self.entries.iter_mut().find(|s| s.name().eq_ignore_ascii_case(strategy.name())) {
            Some(slot) => Some(std::mem::replace(slot, strategy)),
            None => {
                self.entries.push(strategy);
                None
            }
        }
    }

    /// The strategy named `name` (without regard to ASCII case).
    pub fn get(&self, name: &str) -> Result<Arc<dyn ClearingStrategy>, UnknownStrategy> {
        self.entries.iter().find(|s| s.name().eq_ignore_ascii_case(name)).cloned().ok_or_else(|| {
            UnknownStrategy { name: name.to_owned(), known: self.names().map(str::to_owned).collect() }
        })
    }

    /// The names, in registration order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().map(|s| s.name())
    }

    /// The strategies, in registration order.
    pub fn iter(&self) -> impl Iterator<Item = &Arc<dyn ClearingStrategy>> {
        self.entries.iter()
    }

    /// Number of strategies.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the registry has no strategy.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}
