//! Strategies and tactics by name, so a config can assign them and a user crate can add
//! its own.

use std::collections::BTreeMap;

use crate::agent::params::Params;
use crate::agent::strategy::Strategy;
use crate::agent::tactics::Tactic;
use crate::{Error, Result};

/// Creates a strategy from its parameters (and refuses parameters it cannot use).
pub type Factory = Box<dyn Fn(&Params) -> Result<Box<dyn Strategy>> + Send + Sync>;

/// Creates a strategy from its parameters and the tactics registered by name (for
/// strategies composed of tactics a config names).
pub type ComposedFactory = Box<dyn Fn(&Params, &TacticRegistry) -> Result<Box<dyn Strategy>> + Send + Sync>;

/// Creates a tactic from its parameters (and refuses parameters it cannot use).
pub type TacticFactory = Box<dyn Fn(&Params) -> Result<Box<dyn Tactic>> + Send + Sync>;

/// Named, described factories of one kind (`what` names the kind in errors).
struct Named<F> {
    what: &'static str,
    factories: BTreeMap<String, (String, F)>,
}

impl<F> Named<F> {
    fn new(what: &'static str) -> Self {
        Self {
            what,
            factories: BTreeMap::new(),
        }
    }

    fn insert(&mut self, name: &str, description: &str, f: F) {
        self.factories.insert(name.to_owned(), (description.to_owned(), f));
    }

    fn names(&self) -> impl Iterator<Item = &str> {
        self.factories.keys().map(String::as_str)
    }

    fn describe(&self) -> impl Iterator<Item = (&str, &str)> {
        self.factories.iter().map(|(k, (d, _))| (k.as_str(), d.as_str()))
    }

    /// The factory of `name`, or an error listing the known names.
    fn get(&self, name: &str) -> Result<&F> {
        self.factories.get(name).map(|(_, f)| f).ok_or_else(|| {
            Error::InvalidParameter(format!(
                "unknown {} '{name}' (known: {})",
                self.what,
                self.names().collect::<Vec<_>>().join(", ")
            ))
        })
    }

    /// A factory's error, prefixed with what made it.
    fn named(&self, name: &str, e: Error) -> Error {
        match e {
            Error::InvalidParameter(m) => Error::InvalidParameter(format!("{} '{name}': {m}", self.what)),
            other => other,
        }
    }
}

/// Tactics by name: the built-in ones ([`with_builtins`](Self::with_builtins)) and any a
/// user crate registers. Strategies composed of tactics create theirs from here.
pub struct TacticRegistry(Named<TacticFactory>);

impl TacticRegistry {
    /// A registry with no tactics.
    pub fn empty() -> Self {
        Self(Named::new("tactic"))
    }

    /// Add (or replace) a tactic under `name`, with a one-line description.
    pub fn register(
        &mut self,
        name: &str,
        description: &str,
        factory: impl Fn(&Params) -> Result<Box<dyn Tactic>> + Send + Sync + 'static,
    ) {
        self.0.insert(name, description, Box::new(factory));
    }

    /// Names of the registered tactics, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.0.names()
    }

    /// Name and description of each tactic.
    pub fn describe(&self) -> impl Iterator<Item = (&str, &str)> {
        self.0.describe()
    }

    /// Create a tactic by name.
    pub fn create(&self, name: &str, params: &Params) -> Result<Box<dyn Tactic>> {
        self.0.get(name)?(params).map_err(|e| self.0.named(name, e))
    }
}

/// How a registered strategy is made.
enum Maker {
    Plain(Factory),
    Composed(ComposedFactory),
}

/// Strategies by name, and the tactics that strategies composed by name draw on.
pub struct StrategyRegistry {
    strategies: Named<Maker>,
    tactics: TacticRegistry,
}

impl StrategyRegistry {
    /// A registry with no strategies and the built-in tactics.
    pub fn empty() -> Self {
        Self {
            strategies: Named::new("strategy"),
            tactics: TacticRegistry::with_builtins(),
        }
    }

    /// Add (or replace) a strategy under `name`, with a one-line description.
    pub fn register(
        &mut self,
        name: &str,
        description: &str,
        factory: impl Fn(&Params) -> Result<Box<dyn Strategy>> + Send + Sync + 'static,
    ) {
        self.strategies
            .insert(name, description, Maker::Plain(Box::new(factory)));
    }

    /// Add (or replace) a strategy whose factory also gets the tactics registry (to create
    /// the tactics its parameters name).
    pub fn register_composed(
        &mut self,
        name: &str,
        description: &str,
        factory: impl Fn(&Params, &TacticRegistry) -> Result<Box<dyn Strategy>> + Send + Sync + 'static,
    ) {
        self.strategies
            .insert(name, description, Maker::Composed(Box::new(factory)));
    }

    /// The tactics strategies can be composed of.
    pub fn tactics(&self) -> &TacticRegistry {
        &self.tactics
    }

    /// Add tactics (from a user crate) that configs can then name.
    pub fn tactics_mut(&mut self) -> &mut TacticRegistry {
        &mut self.tactics
    }

    /// Names of the registered strategies, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.strategies.names()
    }

    /// Name and description of each strategy.
    pub fn describe(&self) -> impl Iterator<Item = (&str, &str)> {
        self.strategies.describe()
    }

    /// Whether a name is registered.
    pub fn contains(&self, name: &str) -> bool {
        self.strategies.factories.contains_key(name)
    }

    /// Create a strategy by name.
    pub fn create(&self, name: &str, params: &Params) -> Result<Box<dyn Strategy>> {
        match self.strategies.get(name)? {
            Maker::Plain(f) => f(params),
            Maker::Composed(f) => f(params, &self.tactics),
        }
        .map_err(|e| self.strategies.named(name, e))
    }
}
