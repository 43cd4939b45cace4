//! The seam between the analysis and the kinds: what a kind's analysis
//! is ([`AnalysisEntry`], [`KindAnalysis`]), what it is given
//! ([`Context`]) and what it gives back ([`Section`]); the set of kinds
//! hands them over as [`AnalysedKinds`]. Names no kind.

use std::path::Path;

use serde_json::Value;

use super::rows::Rows;
use super::table::Table;
use crate::problem::Problem;
use crate::protocol::kind::{Holds, Kinds, StudyKind};

/// A kind's analysis: how its data files are told, what it reads, and
/// the entry that turns the rows into a report section.
#[derive(Debug, Clone, Copy)]
pub struct AnalysisEntry<K: Kinds> {
    /// A column only this kind's data CSVs have.
    pub marker: &'static str,
    /// The kind's columns the analysis does not need (they may be
    /// missing; every other column must be present).
    pub unread: &'static [&'static str],
    /// Of those, the ones it reads when every data file of the kind has
    /// them (columns added after older files were written).
    pub optional: &'static [&'static str],
    /// It also reads the rows that did not complete, to count them
    /// (`Rows::aborted`).
    pub counts_aborted: bool,
    /// The analysis of the completed, non-practice rows of this kind, with
    /// its [`Context`].
    pub run: RunAnalysis<K>,
    /// Which of its summary's statistics are tests (and intervals) that
    /// power planning counts.
    pub counted: super::counted::CountStatistics,
}

/// A kind's analysis of its rows ([`AnalysisEntry::run`]).
pub type RunAnalysis<K> = fn(rows: &Rows, context: &Context<'_, K>) -> Result<Section, Problem>;

/// How much of an analysis to make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// Everything `analyze` reports: the summary, the tables, every
    /// interval, the HTML report.
    Report,
    /// The summary's statistics that power planning counts (`power`): a
    /// kind may leave out what is costly and not counted (the tables, the
    /// report section, each discrimination track's bootstrap and profile
    /// intervals). The statistics it gives are those of
    /// [`Scope::Report`], bit for bit.
    Counted,
}

/// What a kind's analysis is given besides its rows.
#[derive(Debug)]
pub struct Context<'a, K: Kinds> {
    /// The results folder (for the place of a problem; a replay in memory
    /// names what stands in for it).
    pub folder: &'a Path,
    /// The designs of the sessions analysed (every kind's, in the order of
    /// their files), for what the data CSVs do not hold, such as the
    /// protocol's display order.
    pub designs: &'a [K::Design],
    /// How much to make.
    pub scope: Scope,
}

impl<K: Kinds> Context<'_, K> {
    /// A kind's report section, made only for [`Scope::Report`].
    pub fn report(&self, html: impl FnOnce() -> String) -> String {
        match self.scope {
            Scope::Report => html(),
            Scope::Counted => String::new(),
        }
    }
}

/// A kind's analysis, implemented in its folder beside its
/// [`StudyKind`].
pub trait KindAnalysis: StudyKind {
    /// The kind's analysis in a set of kinds that holds it; `None`: the
    /// kind has none.
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>>;
}

/// A set of kinds with their analyses: the registry, which hands itself to
/// [`analyze`].
pub trait AnalysedKinds: Kinds {
    /// Each kind's name and analysis, in registry order.
    fn analyses() -> Vec<(&'static str, Option<AnalysisEntry<Self>>)>;
}

/// The designs of the kind `S` among `designs`, in order.
pub fn designs_of<S: StudyKind, K: Holds<S>>(
    designs: &[K::Design],
) -> impl Iterator<Item = &S::Design> {
    designs.iter().filter_map(|d| K::design_of(d))
}

/// One kind's part of an analysis, from its [`AnalysisEntry`].
#[derive(Debug, Clone)]
pub struct Section {
    /// The kind's object in `summary.json`.
    pub summary: Value,
    /// Why some statistics are n/a.
    pub notes: Vec<String>,
    /// The kind's tables.
    pub tables: Vec<Table>,
    /// The kind's section of the HTML report.
    pub html: String,
}

impl Section {
    /// The section of a kind's `html` and its analysis's `summary`,
    /// `notes` and `tables`.
    #[must_use]
    pub fn new(html: String, summary: Value, notes: Vec<String>, tables: Vec<Table>) -> Self {
        Self {
            summary,
            notes,
            tables,
            html,
        }
    }
}

/// A finished analysis.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// `summary.json`'s content.
    pub summary: Value,
    /// The tables.
    pub tables: Vec<Table>,
    /// The HTML report.
    pub html: String,
}
