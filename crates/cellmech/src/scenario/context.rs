//! Where a scenario error points: the scenario's name and text, to turn a key's span into
//! a line number.

use std::ops::Range;

use super::ScenarioError;

/// Context for messages: the scenario's name and text.
pub(super) struct Ctx<'a> {
    /// Scenario name (a path or `<built-in: name>`).
    pub origin: &'a str,
    /// Scenario text.
    pub text: &'a str,
}

impl Ctx<'_> {
    /// 1-based line of a span's start; `None` for the empty span of a default value.
    pub fn line(&self, span: Range<usize>) -> Option<usize> {
        let start = span.start.min(self.text.len());
        (span.end > 0).then(|| self.text[..start].matches('\n').count() + 1)
    }

    /// An [`ScenarioError::Invalid`] for `key` at `span` (its line, when known).
    pub fn invalid(
        &self,
        span: Option<Range<usize>>,
        key: &str,
        message: impl Into<String>,
    ) -> ScenarioError {
        ScenarioError::Invalid {
            path: self.origin.into(),
            line: span.and_then(|s| self.line(s)),
            key: key.into(),
            message: message.into(),
        }
    }
}
