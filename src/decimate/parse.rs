//! Typed errors of the decimation settings' `FromStr` impls.

/// A name that is not one of the valid ones (heuristic, estimator); lists the valid names.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} {name:?}; use {}", one_of(.valid))]
pub struct UnknownName {
    /// What was named (`heuristic`, `estimator`).
    pub what: &'static str,
    /// The name given.
    pub name: String,
    /// The valid names.
    pub valid: Vec<&'static str>,
}

impl UnknownName {
    pub(crate) fn new(what: &'static str, name: &str, valid: Vec<&'static str>) -> Self {
        UnknownName {
            what,
            name: name.to_string(),
            valid,
        }
    }
}

/// `a, b or c`.
fn one_of(names: &[&str]) -> String {
    match names {
        [] => String::new(),
        [one] => one.to_string(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// A stop rule that does not parse (see [`super::StopRule`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum StopRuleError {
    /// Not `threshold:W`, `cells:N` or `none`.
    #[error("bad stop rule {0:?}; use threshold:W, cells:N or none")]
    Syntax(String),
    /// `threshold:W` with `W` not finite and positive.
    #[error(
        "bad stop rule {0:?}: W must be a finite number > 0; collapse weights are positive and \
         finite, so this threshold would stop before the first collapse (or never; use `none` \
         to run to the end)"
    )]
    Threshold(String),
    /// `cells:0`.
    #[error(
        "bad stop rule {0:?}: N must be at least 1 (a decimation always leaves at least one \
         cell, so cells:0 would run until no pair is left; use `none` for that)"
    )]
    Cells(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_names() {
        assert_eq!(one_of(&["a", "b", "c"]), "a, b or c");
        assert_eq!(one_of(&["a", "b"]), "a or b");
        assert_eq!(one_of(&["a"]), "a");
    }
}
