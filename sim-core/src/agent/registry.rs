//! Strategies by name, so a config can assign them and a user crate can add its own.

use std::collections::BTreeMap;

use crate::agent::params::Params;
use crate::agent::strategy::Strategy;
use crate::{Error, Result};

/// Creates a strategy from its parameters (and refuses parameters it cannot use).
pub type Factory = Box<dyn Fn(&Params) -> Result<Box<dyn Strategy>> + Send + Sync>;

/// Strategies by name.
pub struct StrategyRegistry {
    factories: BTreeMap<String, (String, Factory)>,
}

impl StrategyRegistry {
    /// A registry with nothing in it.
    pub fn empty() -> Self {
        Self {
            factories: BTreeMap::new(),
        }
    }

    /// Add (or replace) a strategy under `name`, with a one-line description.
    pub fn register(
        &mut self,
        name: &str,
        description: &str,
        factory: impl Fn(&Params) -> Result<Box<dyn Strategy>> + Send + Sync + 'static,
    ) {
        self.factories
            .insert(name.to_owned(), (description.to_owned(), Box::new(factory)));
    }

    /// Names of the registered strategies, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.factories.keys().map(String::as_str)
    }

    /// Name and description of each strategy.
    pub fn describe(&self) -> impl Iterator<Item = (&str, &str)> {
        self.factories.iter().map(|(k, (d, _))| (k.as_str(), d.as_str()))
    }

    /// Whether a name is registered.
    pub fn contains(&self, name: &str) -> bool {
        self.factories.contains_key(name)
    }

    /// Create a strategy by name.
    pub fn create(&self, name: &str, params: &Params) -> Result<Box<dyn Strategy>> {
        match self.factories.get(name) {
            Some((_, f)) => f(params).map_err(|e| match e {
                Error::InvalidParameter(m) => Error::InvalidParameter(format!("strategy '{name}': {m}")),
                other => other,
            }),
            None => Err(Error::InvalidParameter(format!(
                "unknown strategy '{name}' (known: {})",
                self.names().collect::<Vec<_>>().join(", ")
            ))),
        }
    }
}
