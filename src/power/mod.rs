//! Power planning by simulation: replay whole studies with simulated
//! participants drawn from the population, run the same analysis as
//! `analyze` on each, and count how often each test comes out significant.
//!
//! # The plan and its studies
//! A plan ([`Plan`]) is a protocol, the sample sizes, the number of studies
//! per size, a seed, the significance level and the population. Study `s`
//! at size index `i` has the global index `i * studies + s` and runs with
//! the study seed [`study_seed`]`(seed, s)`: participant `j` of it is the
//! same simulated participant at every size (common random numbers: a
//! curve's points differ by the participants added, not by a fresh draw),
//! and a study depends on nothing but its index, so how the studies are
//! split into shards or threads changes no number.
//!
//! # What is counted ([`outcomes`])
//! - paired comparison: `binomial_p`;
//! - magnitude estimation: each delta_mu series' correlation `p`, and the
//!   display effect's `p`;
//! - Fitts: each quadrant entry's `time_sign_p` and `accuracy_sign_p` (per
//!   condition and ID, and pooled), and `accuracy_sign_p` of the error-count
//!   quadrants;
//! - discrimination: each level's width of the 95% CI of the group mean
//!   Weber fraction.
//!
//! A p value counts as significant below `alpha`; power is the share of
//! studies significant, with its Monte Carlo standard error
//! `sqrt(power (1 - power) / studies)`. A study where the test is n/a
//! counts as not significant (and is counted in `na`). A CI width "reaches
//! its target" at most `max_ci_width`; its power is that share (often called
//! assurance). The smallest sample size of a test is the first size whose
//! power reaches `target_power`.
//!
//! # Shards ([`run_shard`], [`merge`])
//! Shard `K` of `N` runs the studies whose study number is `K` modulo `N`,
//! at every size (a study number's sizes share their participants: its
//! sessions run once, in memory, and each size analyses its first ones).
//! Each
//! finished study is appended to `power-shard-K-of-N.partial.jsonl` (fsync'd)
//! before the next is counted, so a killed shard rerun continues where it
//! stopped; when all are done the shard's studies, in index order, go to
//! `power-shard-K-of-N.json` (atomically) and the journal is removed.
//! `power.json` is made from the studies alone, in index order, so a merge of
//! any shards is byte-identical to an unsharded run.
//!
//! The engine reads no clock: the command line times and draws the
//! progress bar through the `progress` callback.

mod report;

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead as _, Write as _};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use crate::analysis::counted::KindCounted;
use crate::analysis::{AnalysedKinds, Scope, Tables, analyze_tables};
use crate::kinds::{Protocol, ReadLog, Registry};
use crate::participant::Population;
use crate::problem::Problem;
use crate::session::{SessionError, Simulation, participant_seed, simulate_in_memory};

pub use report::html;

/// The format tag of power files.
pub const FORMAT: &str = "frictionlab-power/1";

/// Why a power run or merge failed.
#[derive(Debug, thiserror::Error)]
pub enum PowerError {
    /// Bad input: flags, files, a plan that does not match (exit 2).
    #[error("{}", .0.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    Input(Vec<Problem>),
    /// An I/O error on the outputs, at its path.
    #[error("{0}")]
    Io(Problem),
    /// A simulated session failed.
    #[error(transparent)]
    Session(#[from] SessionError),
}

/// An output error at `path` (I/O, a results write, serialization).
fn io<E: std::fmt::Display>(path: &Path) -> impl FnOnce(E) -> PowerError + '_ {
    move |e| PowerError::Io(Problem::new(path.display().to_string(), e.to_string()))
}

fn input(place: impl Into<String>, message: impl Into<String>) -> PowerError {
    PowerError::Input(vec![Problem::new(place, message)])
}

/// What a power run replays and how it counts: everything `power.json`
/// depends on. Shards of one plan must have equal plans.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanHeader {
    /// The protocol's id.
    pub protocol: String,
    /// The protocol's kind.
    pub kind: String,
    /// SHA-256 of the protocol file.
    pub protocol_sha256: String,
    /// Sample sizes, increasing.
    pub participants: Vec<u32>,
    /// Studies per sample size.
    pub studies: u32,
    /// The plan's seed.
    pub seed: u64,
    /// Significance level.
    pub alpha: f64,
    /// The power a sample size must reach.
    pub target_power: f64,
    /// A CI width reaches its target at most this wide (in the statistic's
    /// units: a Weber fraction for discrimination).
    pub max_ci_width: f64,
    /// The population when not the default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub population: Option<Population>,
}

/// A plan: its header and the protocol it replays.
#[derive(Debug, Clone)]
pub struct Plan<'a> {
    /// What `power.json` records of the plan.
    pub header: PlanHeader,
    /// The protocol, parsed.
    pub protocol: &'a Protocol,
    /// Its file's bytes.
    pub protocol_bytes: &'a [u8],
}

impl PlanHeader {
    /// Every problem with the plan's numbers, as (flag, what).
    #[must_use]
    pub fn problems(&self) -> Vec<Problem> {
        let mut out = Vec::new();
        if self.participants.is_empty() {
            out.push(Problem::new("--participants", "give at least one size"));
        }
        if self.participants.first().is_some_and(|&n| n < 2) {
            out.push(Problem::new(
                "--participants",
                "sizes must be at least 2 (a test across participants needs two)",
            ));
        }
        if self.participants.windows(2).any(|w| w[0] >= w[1]) {
            out.push(Problem::new(
                "--participants",
                format!("sizes must increase, got {:?}", self.participants),
            ));
        }
        if self.studies == 0 {
            out.push(Problem::new("--studies", "must be at least 1"));
        }
        for (flag, v) in [("--alpha", self.alpha), ("--power", self.target_power)] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                out.push(Problem::new(flag, format!("must be in (0, 1), got {v}")));
            }
        }
        if !(self.max_ci_width.is_finite() && self.max_ci_width > 0.0) {
            out.push(Problem::new(
                "--max-ci-width",
                format!("must be above 0, got {}", self.max_ci_width),
            ));
        }
        out
    }

    /// How many studies the plan has.
    #[must_use]
    pub fn total(&self) -> u64 {
        self.participants.len() as u64 * u64::from(self.studies)
    }

    /// The sample size and study number of study `index`.
    #[must_use]
    pub fn study(&self, index: u64) -> (u32, u32) {
        let per = u64::from(self.studies.max(1));
        let size = usize::try_from(index / per).unwrap_or(usize::MAX);
        let n = self.participants.get(size).copied().unwrap_or(0);
        (n, u32::try_from(index % per).unwrap_or(0))
    }
}

/// The seed of study `s` of a plan seeded `seed` (the same at every sample
/// size: participant `j` of study `s` is the same at every size).
#[must_use]
pub fn study_seed(seed: u64, s: u32) -> u64 {
    participant_seed(seed ^ 0x706f_7765_7200_0000, s)
}

/// Shard `k` of `n` (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard.
    pub k: u32,
    /// How many shards.
    pub n: u32,
}

impl Shard {
    /// The whole plan in one shard.
    pub const ALL: Shard = Shard { k: 0, n: 1 };

    /// Parses `K/N` (0 <= K < N).
    ///
    /// # Errors
    /// Not two integers, or K not below N.
    pub fn parse(text: &str, place: &str) -> Result<Shard, Problem> {
        let bad = || Problem::new(place, format!("'{text}': expected K/N with 0 <= K < N"));
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (k, n): (u32, u32) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k < n {
            Ok(Shard { k, n })
        } else {
            Err(bad())
        }
    }

    /// The shard of a Slurm array task: `SLURM_ARRAY_TASK_ID` minus
    /// `SLURM_ARRAY_TASK_MIN` (0 when unset) of `SLURM_ARRAY_TASK_COUNT`;
    /// `None` outside an array. `var` reads the environment.
    ///
    /// # Errors
    /// A variable that is not a number, or a task outside the count.
    pub fn from_slurm(var: impl Fn(&str) -> Option<String>) -> Result<Option<Shard>, Problem> {
        let Some(id) = var("SLURM_ARRAY_TASK_ID") else {
            return Ok(None);
        };
        let number = |name: &str, text: &str| -> Result<u32, Problem> {
            text.trim()
                .parse()
                .map_err(|_| Problem::new(name, format!("'{text}' is not a task number")))
        };
        let id = number("SLURM_ARRAY_TASK_ID", &id)?;
        let min =
            var("SLURM_ARRAY_TASK_MIN").map_or(Ok(0), |m| number("SLURM_ARRAY_TASK_MIN", &m))?;
        let count = var("SLURM_ARRAY_TASK_COUNT").ok_or_else(|| {
            Problem::new(
                "SLURM_ARRAY_TASK_COUNT",
                "unset, but SLURM_ARRAY_TASK_ID is set: give --shard K/N",
            )
        })?;
        let count = number("SLURM_ARRAY_TASK_COUNT", &count)?;
        match id.checked_sub(min) {
            Some(k) if k < count => Ok(Some(Shard { k, n: count })),
            _ => Err(Problem::new(
                "SLURM_ARRAY_TASK_ID",
                format!(
                    "task {id} is not one of {count} tasks from {min}: use a contiguous --array such as 0-{}",
                    count.saturating_sub(1)
                ),
            )),
        }
    }

    fn name(self) -> String {
        format!("power-shard-{}-of-{}", self.k, self.n)
    }

    /// The shard's output file in `dir`.
    #[must_use]
    pub fn file(self, dir: &Path) -> PathBuf {
        dir.join(format!("{}.json", self.name()))
    }

    fn journal(self, dir: &Path) -> PathBuf {
        dir.join(format!("{}.partial.jsonl", self.name()))
    }

    /// The lock one process holds while it runs the shard (issue 31: two
    /// runs of one shard would append to one journal). Kept after the run:
    /// removing a lock file races a process about to take it.
    fn lock(self, dir: &Path) -> PathBuf {
        dir.join(format!(".{}.lock", self.name()))
    }

    /// The study indices of this shard, ascending: every sample size of
    /// the study numbers `s` with `s` = K modulo N (a study number's
    /// sizes share their participants, so one shard replays them together).
    fn indices(self, plan: &PlanHeader) -> Vec<u64> {
        let per = u64::from(plan.studies);
        let mut out: Vec<u64> = (0..plan.participants.len() as u64)
            .flat_map(|size| {
                (u64::from(self.k)..per)
                    .step_by(self.n.max(1) as usize)
                    .map(move |s| size * per + s)
            })
            .collect();
        out.sort_unstable();
        out
    }
}

/// One replayed study's outcomes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyRecord {
    /// Global study index.
    pub index: u64,
    /// Its sample size.
    pub participants: u32,
    /// Its study number within the size.
    pub study: u32,
    /// Each test's p value (`None`: n/a).
    pub p: BTreeMap<String, Option<f64>>,
    /// Each CI's width (`None`: n/a).
    pub ci_width: BTreeMap<String, Option<f64>>,
}

/// The tests and intervals power counts, from an analysis summary.
pub type Outcomes = crate::analysis::counted::Counted;

/// The tests power counts, read from an `analyze` summary: each kind's
/// analysis entry names its own ([`crate::analysis::AnalysisEntry::counted`]).
#[must_use]
pub fn outcomes(summary: &Value) -> Outcomes {
    let mut out = Outcomes::default();
    for (kind, entry) in <Registry as AnalysedKinds>::analyses() {
        if let (Some(entry), Some(s)) = (entry, summary.get(kind)) {
            (entry.counted)(s, &mut KindCounted::new(kind, &mut out));
        }
    }
    out
}

/// Replays the studies `indices` of the plan, all of study number `s` (a
/// study at each size asked for), and reads their outcomes. The sessions
/// run in memory, once: participant `j` of study `s` is the same at every
/// size, so the largest size's sessions hold each smaller size's as their
/// first ones. Each study's tables are analysed as `analyze` would a
/// folder of its sessions, for the statistics power counts
/// ([`Scope::Counted`](crate::analysis::Scope::Counted)).
fn run_studies(plan: &Plan<'_>, s: u32, indices: &[u64]) -> Result<Vec<StudyRecord>, PowerError> {
    let sizes: Vec<u32> = indices.iter().map(|&i| plan.header.study(i).0).collect();
    let largest = sizes.iter().copied().max().unwrap_or(0);
    let sim = Simulation {
        protocol: plan.protocol,
        protocol_bytes: plan.protocol_bytes,
        participants: largest,
        seed: study_seed(plan.header.seed, s),
        pace: None,
        streams: false,
        population: plan.header.population.as_ref(),
        jobs: 1,
        stop: None,
        lsl: None,
    };
    let logs = (0..largest)
        .map(|i| simulate_in_memory(&sim, i))
        .collect::<Result<Vec<_>, _>>()?;
    let mut out = Vec::with_capacity(indices.len());
    for (&index, &n) in indices.iter().zip(&sizes) {
        let study: Vec<&ReadLog> = logs.iter().take(n as usize).collect();
        let folder = PathBuf::from(format!("study-{index}"));
        let analysis = Tables::from_logs(&folder, &study)
            .and_then(|t| analyze_tables::<Registry>(&t, Scope::Counted))
            .map_err(|e| PowerError::Input(vec![e]))?;
        let Outcomes { p, ci_width } = outcomes(&analysis.summary);
        out.push(StudyRecord {
            index,
            participants: n,
            study: s,
            p,
            ci_width,
        });
    }
    Ok(out)
}

/// The first line of a shard's journal, and the head of its output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShardHead {
    format: String,
    plan: PlanHeader,
    shard: [u32; 2],
}

/// A shard's output file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShardFile {
    format: String,
    plan: PlanHeader,
    shard: [u32; 2],
    studies: Vec<StudyRecord>,
}

/// How a shard run went.
#[derive(Debug, Clone, PartialEq)]
pub struct ShardOutcome {
    /// The shard's output file.
    pub file: PathBuf,
    /// Its studies, in index order.
    pub studies: Vec<StudyRecord>,
    /// Studies found done in the journal (a rerun after a kill) or in a
    /// finished shard file.
    pub resumed: usize,
    /// Studies run now.
    pub ran: usize,
}

/// Reads a journal: its head and the studies in it. A torn last line (a
/// kill mid-write) is cut off.
fn read_journal(path: &Path) -> Result<Option<(ShardHead, Vec<StudyRecord>)>, PowerError> {
    let file = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io(path)(e)),
    };
    let place = |line: usize| format!("{}: {line}:1", path.display());
    let mut reader = std::io::BufReader::new(file);
    let (mut good, mut head, mut studies) = (0_u64, None, Vec::new());
    let mut line = String::new();
    for number in 1.. {
        line.clear();
        let read = reader.read_line(&mut line).map_err(io(path))?;
        if read == 0 || !line.ends_with('\n') {
            break;
        }
        if head.is_none() {
            head = Some(
                serde_json::from_str::<ShardHead>(&line)
                    .map_err(|e| input(place(number), format!("not a power journal: {e}")))?,
            );
        } else {
            studies.push(
                serde_json::from_str::<StudyRecord>(&line)
                    .map_err(|e| input(place(number), e.to_string()))?,
            );
        }
        good += read as u64;
    }
    let Some(head) = head else {
        return Ok(None);
    };
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(io(path))?;
    f.set_len(good).map_err(io(path))?;
    f.sync_all().map_err(io(path))?;
    Ok(Some((head, studies)))
}

/// The studies a journal already holds (a rerun after a kill), or a new
/// journal with its head.
fn open_journal(
    journal: &Path,
    head: &ShardHead,
) -> Result<BTreeMap<u64, StudyRecord>, PowerError> {
    match read_journal(journal)? {
        Some((old, _)) if old != *head => Err(input(
            journal.display().to_string(),
            "a journal of another plan or shard: give another --out, or remove it",
        )),
        Some((_, studies)) => Ok(studies.into_iter().map(|s| (s.index, s)).collect()),
        None => {
            let mut f = std::fs::File::create(journal).map_err(io(journal))?;
            append_line(&mut f, journal, head)?;
            Ok(BTreeMap::new())
        }
    }
}

fn append_line(
    file: &mut std::fs::File,
    path: &Path,
    value: &impl Serialize,
) -> Result<(), PowerError> {
    let mut line = serde_json::to_vec(value).map_err(io(path))?;
    line.push(b'\n');
    file.write_all(&line).map_err(io(path))?;
    file.sync_data().map_err(io(path))
}

/// Runs shard `shard` of `plan` into `out` on `jobs` threads, continuing a
/// journal a killed run left; `progress(done, total)` after each study.
///
/// # Errors
/// A journal or shard file of another plan in `out` (input), I/O, or a
/// failed session.
pub fn run_shard(
    plan: &Plan<'_>,
    shard: Shard,
    out: &Path,
    jobs: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<ShardOutcome, PowerError> {
    let head = ShardHead {
        format: FORMAT.into(),
        plan: plan.header.clone(),
        shard: [shard.k, shard.n],
    };
    let file = shard.file(out);
    let indices: Vec<u64> = shard.indices(&plan.header);
    std::fs::create_dir_all(out).map_err(io(out))?;
    let lock = shard.lock(out);
    let _held = crate::results::lock_file(&lock)
        .map_err(io(&lock))?
        .map_err(|holder| {
            input(
                shard.journal(out).display().to_string(),
                format!(
                    "shard {}/{} of this plan is being run by another process{}: wait for it to end, or give another --out",
                    shard.k,
                    shard.n,
                    holder.pid_text()
                ),
            )
        })?;
    if file.exists() {
        let done = read_shard(&file)?;
        if done.plan != head.plan || done.shard != head.shard {
            return Err(input(
                file.display().to_string(),
                "holds a shard of another plan: give another --out, or remove it",
            ));
        }
        progress(indices.len(), indices.len());
        return Ok(ShardOutcome {
            file,
            resumed: done.studies.len(),
            studies: done.studies,
            ran: 0,
        });
    }
    let journal = shard.journal(out);
    let mut found = open_journal(&journal, &head)?;
    let resumed = found.len();
    // The studies left, by study number: each number's sizes replay
    // together.
    let mut todo: BTreeMap<u32, Vec<u64>> = BTreeMap::new();
    for &i in indices.iter().filter(|i| !found.contains_key(i)) {
        todo.entry(plan.header.study(i).1).or_default().push(i);
    }
    let todo: Vec<(u32, Vec<u64>)> = todo.into_iter().collect();
    let ran = todo.iter().map(|(_, i)| i.len()).sum();
    let journal_file = std::sync::Mutex::new(
        std::fs::OpenOptions::new()
            .append(true)
            .open(&journal)
            .map_err(io(&journal))?,
    );
    let done = std::sync::atomic::AtomicUsize::new(resumed);
    progress(resumed, indices.len());
    for records in crate::parallel::run(&todo, jobs, |(s, todo)| {
        let records = run_studies(plan, *s, todo)?;
        let mut f = journal_file
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        for record in &records {
            append_line(&mut f, &journal, record)?;
        }
        // Counted and reported under the journal's lock, so the counts
        // reach `progress` in order, however fast studies end.
        let count =
            done.fetch_add(records.len(), std::sync::atomic::Ordering::Relaxed) + records.len();
        progress(count, indices.len());
        drop(f);
        Ok::<_, PowerError>(records)
    }) {
        for record in records? {
            found.insert(record.index, record);
        }
    }
    let studies: Vec<StudyRecord> = found.into_values().collect();
    if studies.iter().map(|s| s.index).ne(indices.iter().copied()) {
        return Err(input(
            journal.display().to_string(),
            "holds studies that are not this shard's: remove it and rerun the shard",
        ));
    }
    let shard_file = ShardFile {
        format: FORMAT.into(),
        plan: plan.header.clone(),
        shard: [shard.k, shard.n],
        studies,
    };
    let bytes = pretty(&shard_file, &file)?;
    crate::results::replace_file(&file, &bytes, true).map_err(io(&file))?;
    std::fs::remove_file(&journal).map_err(io(&journal))?;
    Ok(ShardOutcome {
        file,
        ran,
        resumed,
        studies: shard_file.studies,
    })
}

fn pretty(value: &impl Serialize, path: &Path) -> Result<Vec<u8>, PowerError> {
    let mut bytes = serde_json::to_vec_pretty(value).map_err(io(path))?;
    bytes.push(b'\n');
    Ok(bytes)
}

fn read_shard(path: &Path) -> Result<ShardFile, PowerError> {
    let file: ShardFile =
        crate::problem::read_json_file(path).map_err(|e| PowerError::Input(vec![e]))?;
    if file.format != FORMAT {
        return Err(input(
            format!("{}: $.format", path.display()),
            format!("'{}': expected '{FORMAT}'", file.format),
        ));
    }
    Ok(file)
}

/// A shard file read, and where.
type Found = (PathBuf, ShardFile);

/// Every shard file in `dirs` (sorted by name within a folder), and a
/// problem for each shard that has not finished.
fn read_shards(dirs: &[PathBuf]) -> Result<(Vec<Found>, Vec<Problem>), PowerError> {
    let mut shards = Vec::new();
    let mut problems = Vec::new();
    for dir in dirs {
        let entries = std::fs::read_dir(dir).map_err(|e| {
            input(
                dir.display().to_string(),
                format!("cannot read the folder: {e}"),
            )
        })?;
        let mut names: Vec<String> = entries
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("power-shard-"))
            .collect();
        names.sort();
        for name in names {
            let path = dir.join(&name);
            if let Some(stem) = name.strip_suffix(".partial.jsonl") {
                let running = crate::results::open_elsewhere(&dir.join(format!(".{stem}.lock")));
                problems.push(Problem::new(
                    path.display().to_string(),
                    match running {
                        Some(holder) => format!(
                            "a shard still running in another process{}: merge once it has ended",
                            holder.pid_text()
                        ),
                        None => {
                            "a shard that has not finished (killed): rerun it with the same options"
                                .to_owned()
                        }
                    },
                ));
            } else if path.extension().is_some_and(|e| e == "json") {
                shards.push((path.clone(), read_shard(&path)?));
            }
        }
    }
    Ok((shards, problems))
}

/// Reads every shard file in `dirs` and checks that they are the shards
/// `0..N` of one plan, each exactly once, each with exactly its studies.
/// Returns the plan and all studies in index order.
///
/// # Errors
/// No shards, shards of different plans or counts, a missing or duplicated
/// shard, a shard still running (its journal without its file), or an
/// unreadable file.
pub fn merge(dirs: &[PathBuf]) -> Result<(PlanHeader, Vec<StudyRecord>), PowerError> {
    let (shards, mut problems) = read_shards(dirs)?;
    let Some((first_path, first)) = shards.first() else {
        if !problems.is_empty() {
            // Only unfinished shards: say which, and whether they run.
            return Err(PowerError::Input(problems));
        }
        return Err(input(
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            "no power-shard-K-of-N.json files here",
        ));
    };
    let (plan, count) = (first.plan.clone(), first.shard[1]);
    let mut seen: BTreeMap<u32, &Path> = BTreeMap::new();
    for (path, s) in &shards {
        let place = path.display().to_string();
        if s.plan != plan {
            problems.push(Problem::new(
                format!("{place}: $.plan"),
                format!("another plan than {}'s", first_path.display()),
            ));
        } else if s.shard[1] != count {
            problems.push(Problem::new(
                format!("{place}: $.shard"),
                format!(
                    "shard {} of {}, but {} is one of {count}",
                    s.shard[0],
                    s.shard[1],
                    first_path.display()
                ),
            ));
        } else if let Some(other) = seen.insert(s.shard[0], path) {
            problems.push(Problem::new(
                place,
                format!(
                    "shard {} of {count} twice: also {}",
                    s.shard[0],
                    other.display()
                ),
            ));
        } else {
            let want = Shard {
                k: s.shard[0],
                n: count,
            }
            .indices(&plan);
            if s.studies.iter().map(|r| r.index).ne(want) {
                problems.push(Problem::new(
                    format!("{place}: $.studies"),
                    "not this shard's studies in index order",
                ));
            }
        }
    }
    let missing: Vec<String> = (0..count)
        .filter(|k| !seen.contains_key(k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        problems.push(Problem::new(
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            format!(
                "shard(s) {} of {count} missing: rerun them with --shard K/{count} (found {})",
                missing.join(", "),
                seen.keys()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    if !problems.is_empty() {
        return Err(PowerError::Input(problems));
    }
    let mut studies: Vec<StudyRecord> = shards.into_iter().flat_map(|(_, s)| s.studies).collect();
    studies.sort_by_key(|s| s.index);
    Ok((plan, studies))
}

/// One sample size's estimate of one test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Point {
    /// Sample size.
    pub participants: u32,
    /// Studies replayed.
    pub studies: u32,
    /// Studies where it was significant (or the width reached its target).
    pub hits: u32,
    /// Studies where it was n/a.
    pub na: u32,
    /// `hits / studies`.
    pub power: f64,
    /// Monte Carlo standard error of `power`.
    pub mcse: f64,
    /// CI widths: their mean over the studies where one was computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_width: Option<f64>,
    /// CI widths: the Monte Carlo standard error of that mean.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_width_mcse: Option<f64>,
}

/// `power.json`: the plan, then per test its points and smallest size.
#[must_use]
pub fn summarize(plan: &PlanHeader, studies: &[StudyRecord]) -> Value {
    let mut p_names = BTreeSet::new();
    let mut w_names = BTreeSet::new();
    for s in studies {
        p_names.extend(s.p.keys().cloned());
        w_names.extend(s.ci_width.keys().cloned());
    }
    let point = |n: u32, values: Vec<Option<f64>>, hit: &dyn Fn(f64) -> bool, widths: bool| {
        let count = values.len();
        let hits = values.iter().flatten().filter(|v| hit(**v)).count();
        let present: Vec<f64> = values.iter().flatten().copied().collect();
        let power = hits as f64 / count.max(1) as f64;
        let mean = (widths && !present.is_empty())
            .then(|| present.iter().sum::<f64>() / present.len() as f64);
        let mean_mcse = mean.filter(|_| present.len() >= 2).map(|m| {
            let var =
                present.iter().map(|w| (w - m).powi(2)).sum::<f64>() / (present.len() - 1) as f64;
            (var / present.len() as f64).sqrt()
        });
        Point {
            participants: n,
            studies: u32::try_from(count).unwrap_or(u32::MAX),
            hits: u32::try_from(hits).unwrap_or(u32::MAX),
            na: u32::try_from(count - present.len()).unwrap_or(u32::MAX),
            power,
            mcse: (power * (1.0 - power) / count.max(1) as f64).sqrt(),
            mean_width: mean,
            mean_width_mcse: mean_mcse,
        }
    };
    let curve = |name: &String, widths: bool| -> Value {
        let points: Vec<Point> = plan
            .participants
            .iter()
            .map(|&n| {
                let values: Vec<Option<f64>> = studies
                    .iter()
                    .filter(|s| s.participants == n)
                    .map(|s| {
                        let map = if widths { &s.ci_width } else { &s.p };
                        map.get(name).copied().flatten()
                    })
                    .collect();
                if widths {
                    point(n, values, &|w| w <= plan.max_ci_width, true)
                } else {
                    point(n, values, &|p| p < plan.alpha, false)
                }
            })
            .collect();
        let smallest = points
            .iter()
            .find(|p| p.power >= plan.target_power)
            .map(|p| p.participants);
        json!({
            "name": name,
            "statistic": if widths { "ci_width" } else { "p" },
            "smallest_n": smallest,
            "points": points,
        })
    };
    let tests: Vec<Value> = p_names
        .iter()
        .map(|n| curve(n, false))
        .chain(w_names.iter().map(|n| curve(n, true)))
        .collect();
    json!({
        "format": FORMAT,
        "plan": plan,
        "definitions": {
            "power": "share of studies with p < alpha (p values), or with the CI width <= max_ci_width (ci_width); a study where the statistic is n/a counts as a miss and in na",
            "mcse": "Monte Carlo standard error, sqrt(power (1 - power) / studies)",
            "smallest_n": "the first sample size whose power reaches target_power; null if none does",
        },
        "tests": tests,
    })
}

/// Writes `power.json` and `power.html` into `out` (atomically).
///
/// # Errors
/// I/O, at the file's path.
pub fn write(out: &Path, power: &Value) -> Result<(), PowerError> {
    let json_path = out.join("power.json");
    let bytes = pretty(power, &json_path)?;
    let write = |path: &Path, bytes: &[u8]| {
        crate::results::replace_file(path, bytes, true).map_err(io(path))
    };
    write(&json_path, &bytes)?;
    write(&out.join("power.html"), html(power).as_bytes())
}
