//! The one value checker of the scene format: a [`Validator`] knows the file (and the table, for a prefix of
//! the dotted keys) and turns each failed check into a [`SceneError::Invalid`] with the same wording wherever the
//! check is made: the scene's own tables (`build.rs`), `[material]` and material files (`material.rs`) and
//! `[garment]` (`garment.rs`).

use super::error::SceneError;
use super::spec::NamedSet;
use crate::grid::Grid;
use crate::math::Vec3;
use std::fmt::Display;
use std::ops::RangeInclusive;
use std::path::Path;

/// Checks values read from `file`; keys are given relative to the table `prefix` (empty: the top level).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Validator<'a> {
    file: &'a Path,
    prefix: &'a str,
}

impl<'a> Validator<'a> {
    /// Checks the top level of `file`.
    pub(crate) fn new(file: &'a Path) -> Self {
        Self { file, prefix: "" }
    }

    /// Checks the table `prefix` of `file` (`material`, `garment`; empty for the top level).
    pub(crate) fn within(file: &'a Path, prefix: &'a str) -> Self {
        Self { file, prefix }
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

    /// `Ok` when `ok`, else the error for `key` with `message()`.
    pub(crate) fn require(&self, key: &str, ok: bool, message: impl FnOnce() -> String) -> Result<(), SceneError> {
        if ok {
            Ok(())
        } else {
            Err(self.bad(key, message()))
        }
    }

    /// Three finite numbers.
    pub(crate) fn finite3(&self, key: &str, v: [f64; 3]) -> Result<Vec3, SceneError> {
        if v.iter().all(|c| c.is_finite()) {
            Ok(Vec3::from_array(v))
        } else {
            Err(self.bad(key, format!("{v:?} must be three finite numbers")))
        }
    }

    /// A positive finite number in `unit`.
    pub(crate) fn positive(&self, key: &str, v: f64, unit: &str) -> Result<f64, SceneError> {
        if !v.is_finite() {
            Err(self.bad(key, format!("{v} {unit} must be a finite number")))
        } else if v <= 0.0 {
            Err(self.bad(key, format!("{v} {unit} must be positive")))
        } else {
            Ok(v)
        }
    }

    /// A finite number, zero or more, in `unit`.
    pub(crate) fn non_negative(&self, key: &str, v: f64, unit: &str) -> Result<f64, SceneError> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.bad(key, format!("{v} {unit} must be finite and non-negative")))
        }
    }

    /// A positive finite length in metres (the wording of `[garment]`).
    pub(crate) fn positive_length(&self, key: &str, v: f64) -> Result<f64, SceneError> {
        self.require(key, v.is_finite() && v > 0.0, || format!("{v} m must be a positive, finite length"))?;
        Ok(v)
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
