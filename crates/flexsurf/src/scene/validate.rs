//! The one value checker of the scene format: a [`Validator`] knows the file (and the table, for a prefix of
//! the dotted keys) and turns each failed check into a [`SceneError::Invalid`] with the same wording wherever the
//! check is made: the scene's own tables (`build.rs`), `[material]` and material files (`material.rs`) and
//! `[garment]` (`garment.rs`). Numbers are checked against their entry of the range table
//! ([`super::ranges`]): an error outside the hard bounds, a [`SceneWarning`] (collected, not printed)
//! outside the usual range of fabrics.

use super::error::{SceneError, SceneWarning};
use super::ranges::Range;
use super::spec::NamedSet;
use crate::grid::Grid;
use std::cell::RefCell;
use std::fmt::Display;
use std::ops::RangeInclusive;
use std::path::Path;

/// Where the warnings of one scene (and the files it references) are collected.
pub(crate) type Warnings = RefCell<Vec<SceneWarning>>;

/// Checks values read from `file`; keys are given relative to the table `prefix` (empty: the top level).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Validator<'a> {
    file: &'a Path,
    prefix: &'a str,
    /// Messages may quote the file's values (not for files other than the scene: material files).
    echo: bool,
    warnings: &'a Warnings,
}

impl<'a> Validator<'a> {
    /// Checks the top level of the scene file `file`, collecting warnings into `warnings`.
    pub(crate) fn new(file: &'a Path, warnings: &'a Warnings) -> Self {
        Self { file, prefix: "", echo: true, warnings }
    }

    /// Checks a file other than the scene (a material file): its messages never quote its values.
    pub(crate) fn foreign(file: &'a Path, warnings: &'a Warnings) -> Self {
        Self { file, prefix: "", echo: false, warnings }
    }

    /// The same checker for the table `prefix` of the file (`material`; empty for the top level).
    pub(crate) fn within(&self, prefix: &'a str) -> Self {
        Self { prefix, ..*self }
    }

    /// Records a warning about `key`.
    pub(crate) fn warn(&self, key: &str, message: String) {
        let file = self.file.display().to_string();
        self.warnings.borrow_mut().push(SceneWarning { file, key: self.key(key), message });
    }

    /// Adds the warnings of a referenced file.
    pub(crate) fn extend(&self, warnings: Vec<SceneWarning>) {
        self.warnings.borrow_mut().extend(warnings);
    }

    /// The file checked.
    pub(crate) fn file(&self) -> &'a Path {
        self.file
    }

    /// The dotted key of `key` in this table (the table itself for an empty `key`).
    pub(crate) fn key(&self, key: &str) -> String {
        match (self.prefix.is_empty(), key.is_empty()) {
            (true, _) => key.to_string(),
            (false, true) => self.prefix.to_string(),
            (false, false) => format!("{}.{key}", self.prefix),
        }
    }

    /// The error for `key`.
    pub(crate) fn bad(&self, key: &str, message: String) -> SceneError {
        SceneError::invalid(self.file, self.key(key), message)
    }

    /// The error for `key` whose `value` is `what` (`must be positive`), quoting the value unless the file is
    /// not the scene.
    pub(crate) fn bad_value(&self, key: &str, value: f64, what: &str) -> SceneError {
        self.bad(key, if self.echo { format!("{value}: {what}") } else { what.to_string() })
    }

    /// `Ok` when `ok`, else the error for `key` with `message()`.
    pub(crate) fn require(&self, key: &str, ok: bool, message: impl FnOnce() -> String) -> Result<(), SceneError> {
        if ok {
            Ok(())
        } else {
            Err(self.bad(key, message()))
        }
    }

    /// `value` of `key` checked against its entry `range` of the range table: an error when it breaks the
    /// entry's sign rule or hard bounds, a warning when it lies outside the usual range of fabrics.
    pub(crate) fn number(&self, range: &Range, key: &str, value: f64) -> Result<f64, SceneError> {
        if let Some(problem) = range.problem(value, self.echo) {
            return Err(self.bad(key, problem));
        }
        if let Some(note) = range.unusual(value, self.echo) {
            self.warn(key, note);
        }
        Ok(value)
    }

    /// As [`Validator::number`] for each component of `values` (positions, vectors, sizes).
    pub(crate) fn numbers<const N: usize>(
        &self,
        range: &Range,
        key: &str,
        values: [f64; N],
    ) -> Result<[f64; N], SceneError> {
        for value in values {
            self.number(range, key, value)?;
        }
        Ok(values)
    }

    /// A count of at least `min`.
    pub(crate) fn at_least(&self, key: &str, v: usize, min: usize) -> Result<usize, SceneError> {
        self.require(key, v >= min, || format!("must be at least {min}"))?;
        Ok(v)
    }

    /// A value within `range`.
    pub(crate) fn in_range<T: PartialOrd + Display>(
        &self,
        key: &str,
        v: T,
        range: RangeInclusive<T>,
    ) -> Result<T, SceneError> {
        let ok = range.contains(&v);
        self.require(key, ok, || format!("must be between {} and {}", range.start(), range.end()))?;
        Ok(v)
    }

    /// Flat node indices of a named set plus explicit `[i, j]` pairs on `grid`; `key` names the table.
    pub(crate) fn node_set(
        &self,
        grid: &Grid,
        set: Option<NamedSet>,
        nodes: &[[usize; 2]],
        key: &str,
    ) -> Result<Vec<usize>, SceneError> {
        let (m, n) = (grid.m, grid.n);
        let mut out = Vec::new();
        if let Some(set) = set {
            match set {
                NamedSet::Corners => {
                    if grid.periodic(0) || grid.periodic(1) {
                        return Err(self.bad(&format!("{key}.set"), "`corners` needs both directions free".into()));
                    }
                    out.extend([
                        grid.index(0, 0),
                        grid.index(m - 1, 0),
                        grid.index(0, n - 1),
                        grid.index(m - 1, n - 1),
                    ]);
                }
                NamedSet::EdgeU1Start => out.extend((0..n).map(|j| grid.index(0, j))),
                NamedSet::EdgeU1End => out.extend((0..n).map(|j| grid.index(m - 1, j))),
                NamedSet::EdgeU2Start => out.extend((0..m).map(|i| grid.index(i, 0))),
                NamedSet::EdgeU2End => out.extend((0..m).map(|i| grid.index(i, n - 1))),
                NamedSet::All => out.extend(0..grid.len()),
            }
        }
        for &[i, j] in nodes {
            if i >= m || j >= n {
                return Err(self.bad(
                    &format!("{key}.nodes"),
                    format!("node [{i}, {j}] is outside the {m} × {n} grid (indices start at 0)"),
                ));
            }
            out.push(grid.index(i, j));
        }
        if out.is_empty() {
            return Err(self.bad(key, "give `set` or `nodes`".into()));
        }
        Ok(out)
    }
}
