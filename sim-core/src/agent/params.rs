//! Named parameters of a strategy, as the config gives them, read with checked ranges.

use std::collections::BTreeMap;
use std::ops::RangeInclusive;

use crate::{Error, Result};

/// Longest distance a parameter may name (1,000 km: beyond any map).
pub(crate) const MAX_DISTANCE_M: f64 = 1e6;
/// Most rounds a parameter may name (a billion: beyond any run, and far from overflowing
/// when added to a round number).
pub(crate) const MAX_ROUNDS: u64 = 1_000_000_000;

/// Named parameters of a strategy, from the config.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params(BTreeMap<String, String>);

impl Params {
    /// Parameters from pairs.
    pub fn from_pairs<'a>(pairs: impl IntoIterator<Item = (&'a str, &'a str)>) -> Self {
        Self(pairs.into_iter().map(|(k, v)| (k.to_owned(), v.to_owned())).collect())
    }
    /// Add (or replace) one parameter.
    pub fn with(mut self, name: impl Into<String>, value: impl Into<String>) -> Self {
        self.0.insert(name.into(), value.into());
        self
    }
    /// The parameters, by name.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &str)> {
        self.0.iter().map(|(k, v)| (k.as_str(), v.as_str()))
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// A parameter's text, if given.
    pub fn text(&self, name: &str) -> Option<&str> {
        self.0.get(name).map(String::as_str)
    }

    /// A point `X,Y` in metres, if given.
    pub fn point(&self, name: &str) -> Result<Option<glam::DVec2>> {
        let Some(v) = self.0.get(name) else {
            return Ok(None);
        };
        let xy: Option<Vec<f64>> = v.split(',').map(|c| c.trim().parse::<f64>().ok()).collect();
        match xy.as_deref() {
            Some(&[x, y]) if x.is_finite() && y.is_finite() => Ok(Some(glam::DVec2::new(x, y))),
            _ => Err(invalid(format!(
                "parameter '{name}' must be a point X,Y in metres, got '{v}'"
            ))),
        }
    }

    /// The parameters named `PREFIX.NAME`, as `NAME` (a composed strategy hands each of its
    /// parts its own).
    pub fn prefixed(&self, prefix: &str) -> Params {
        self.0
            .iter()
            .filter_map(|(k, v)| {
                k.strip_prefix(prefix)
                    .and_then(|rest| rest.strip_prefix('.'))
                    .map(|rest| (rest.to_owned(), v.clone()))
            })
            .collect()
    }

    /// A number in `range`, or `default` when absent.
    pub fn f64_in(&self, name: &str, default: f64, range: RangeInclusive<f64>) -> Result<f64> {
        let Some(v) = self.0.get(name) else {
            return Ok(default);
        };
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| range.contains(x))
            .ok_or_else(|| {
                invalid(format!(
                    "parameter '{name}' must be a number in [{}, {}], got '{v}'",
                    range.start(),
                    range.end()
                ))
            })
    }
    /// A number in `range`, or `None` when absent.
    pub fn opt_f64_in(&self, name: &str, range: RangeInclusive<f64>) -> Result<Option<f64>> {
        self.0
            .contains_key(name)
            .then(|| self.f64_in(name, 0.0, range))
            .transpose()
    }
    /// A whole number in `range`, or `default` when absent.
    pub fn u64_in(&self, name: &str, default: u64, range: RangeInclusive<u64>) -> Result<u64> {
        let Some(v) = self.0.get(name) else {
            return Ok(default);
        };
        v.trim()
            .parse::<u64>()
            .ok()
            .filter(|x| range.contains(x))
            .ok_or_else(|| {
                invalid(format!(
                    "parameter '{name}' must be a whole number in [{}, {}], got '{v}'",
                    range.start(),
                    range.end()
                ))
            })
    }
    /// Fail on parameters the strategy does not know.
    pub fn only(&self, known: &[&str]) -> Result<()> {
        match self.0.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => Err(invalid(format!(
                "unknown parameter '{k}' (known: {})",
                if known.is_empty() {
                    "none".to_owned()
                } else {
                    known.join(", ")
                }
            ))),
            None => Ok(()),
        }
    }
}

impl FromIterator<(String, String)> for Params {
    fn from_iter<I: IntoIterator<Item = (String, String)>>(iter: I) -> Self {
        Self(iter.into_iter().collect())
    }
}

fn invalid(message: String) -> Error {
    Error::InvalidParameter(message)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::float_cmp)] // the values are exact decimal literals parsed back
    fn ranges_are_checked_and_absent_values_default() {
        let p = Params::from_pairs([("a", "2.5"), ("n", "7"), ("big", "18446744073709551615")]);
        assert_eq!(p.f64_in("a", 0.0, 0.0..=3.0).unwrap(), 2.5);
        assert!(p.f64_in("a", 0.0, 0.0..=2.0).is_err());
        assert_eq!(p.f64_in("missing", 1.5, 0.0..=1.0).unwrap(), 1.5);
        assert_eq!(p.u64_in("n", 0, 1..=10).unwrap(), 7);
        assert!(p.u64_in("big", 0, 0..=1_000_000).is_err());
        let err = p.only(&["a", "n"]).unwrap_err().to_string();
        assert!(err.contains("unknown parameter 'big'") && err.contains("a, n"), "{err}");
    }
}
